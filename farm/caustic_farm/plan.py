"""Cutting frames into sample chunks (pure: no cluster, no files)."""

from dataclasses import dataclass


@dataclass(frozen=True)
class Chunk:
    """Samples [offset, offset + spp) of frame `frame`."""

    frame: int
    offset: int
    spp: int

    @property
    def samples(self):
        """The half-open sample range as a list, as the chunk files and progress lines state it."""
        return [self.offset, self.offset + self.spp]


def plan_chunks(frames, spp, chunks_per_frame):
    """Split each of `frames` frames of `spp` samples into at most `chunks_per_frame` chunks
    of nearly equal size (sizes differ by at most one; no empty chunk)."""
    if frames < 1 or spp < 1 or chunks_per_frame < 1:
        raise ValueError("frames, spp and chunks per frame must be at least 1")
    k = min(chunks_per_frame, spp)
    out = []
    for f in range(frames):
        offset = 0
        for i in range(k):
            n = spp // k + (1 if i < spp % k else 0)
            out.append(Chunk(f, offset, n))
            offset += n
    return out
