"""Node-graph material edits in the Rendered viewport: the `material_graph` request
(docs/protocol.md).

A material the running scene holds as a shader node graph (`CAUSTIC_materials_nodes`) is
exported again alone, graph only, by the final render's own functions (`materials.graph_of`,
`node_images.ImageWriter.graph_value`), and the server compiles it in place: a procedural
tweak (a Noise Texture's Scale) keeps the scene and its BVH. The graph's images are named by
the entries the last full export wrote, so nothing is written; an image that export did not
write, a medium or subsurface that changed (the loader takes them from other extensions),
or a material that glTF can now express instead needs the whole export: `GraphRefused`, and
the viewport reloads.
"""

from .errors import CausticError
from .export.materials import graph_of, uses_graph
from .export.media import medium_extension, subsurface_extension
from .export.node_images import ImageWriter
from .export.state import ExportState

MATERIAL_GRAPH = "material_graph"


class GraphRefused(CausticError):
    """The edit needs the whole scene exported again."""


def graph_extras(material):
    """What the loader keeps of a node-graph material beside its graph (its medium and
    subsurface extensions): a change there is not a graph edit."""
    return medium_extension(material)[0], subsurface_extension(material)[0]


class _KnownImages(ImageWriter):
    """An ImageWriter that writes nothing: it names the images the last export wrote
    (image pointer -> entry, or None for an image without pixels, as that export dropped it)."""

    def __init__(self, entries):
        super().__init__(None)
        self.written = dict(entries)

    def _write(self, image, what, warnings):
        raise GraphRefused(f"{what}: image '{image.name}' is not in the running scene")


def graph_request(material, depsgraph, images):
    """The `material_graph` request for `material`, its graph exported as the final render
    exports it, with the images of `images` (the last export's entries); returns (header,
    warnings). Raises GraphRefused when the edit needs the scene exported again."""
    state = ExportState(None)
    state.depsgraph = depsgraph
    state.material_override = depsgraph.view_layer.material_override
    if state.material_override is not None:
        raise GraphRefused("a view layer material override is exported with every mesh")
    if not uses_graph(material, state):
        raise GraphRefused(f"material '{material.name}' is no longer exported as a node graph")
    graph = graph_of(material, state)
    warnings = list(graph.warnings)
    value = _KnownImages(images).graph_value(graph, f"material '{material.name}'", warnings)
    return {"type": MATERIAL_GRAPH, "name": material.name, "nodes": value}, warnings
