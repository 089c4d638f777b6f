"""Writes scenes/fog_caustic.gltf: the glass caustic scene (scenes/glass_caustic.gltf, whose
buffer it shares) filled with grey fog, so that the clear glass sphere focuses the small
emissive quad's light into a cone of light in the fog (a volumetric caustic: light -> glass
-> fog -> camera), which the path tracer finds only by hitting the quad through the glass.

Standard library only; deterministic output. Run after make_glass_caustic.py:
python3 scenes/make_fog_caustic.py
"""

import json
import os

HERE = os.path.dirname(os.path.abspath(__file__))

with open(os.path.join(HERE, "glass_caustic.gltf")) as f:
    doc = json.load(f)
doc["asset"]["generator"] = "caustic scenes/make_fog_caustic.py"
doc["extensionsUsed"].append("CAUSTIC_world")
scene = doc["scenes"][0]
scene["name"] = "fog_caustic"
# Fog of mean free path 2.5 scene units (the room is about 2 across): thin enough that
# the cone under the sphere is lit, thick enough to show it; no ambient light.
scene["extensions"] = {"CAUSTIC_world": {"color": [0, 0, 0], "medium": {
    "density": 0.15, "scatter_color": [1.0, 1.0, 1.0], "anisotropy": 0.0}}}
with open(os.path.join(HERE, "fog_caustic.gltf"), "w") as f:
    json.dump(doc, f, indent=1, sort_keys=True)
    f.write("\n")
