"""caustic_farm: render Caustic frames on a Dask cluster.

Each frame (one scene file) is split into chunks of its samples (`caustic render
--sample-offset N --spp K --chunk`), the chunks render on any worker, and `caustic merge`
adds them into exactly the image a single render gives. `plan` cuts the work, `scene_files`
finds and hashes what a scene needs, `tasks` is what runs on the workers, `driver` submits,
retries, reports and cancels, `cli` is the command (`python -m caustic_farm`).
"""

from .driver import FarmError, FarmResult, render_frames
from .plan import Chunk, plan_chunks

__all__ = ["Chunk", "FarmError", "FarmResult", "plan_chunks", "render_frames"]
