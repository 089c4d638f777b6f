"""The frame Blender asks for: its full size and the window (render border) to render."""

import struct


def _f32(x):
    return struct.unpack("f", struct.pack("f", x))[0]


class FrameWindow:
    """The full frame size and the pixel window Blender wants rendered (the border, if any)."""

    def __init__(self, render):
        # Blender's own integer arithmetic: size = resolution * percentage / 100, truncated.
        self.width = render.resolution_x * render.resolution_percentage // 100
        self.height = render.resolution_y * render.resolution_percentage // 100
        # Blender's border rectangle, bottom-left origin, from float32 products truncated to
        # int as Blender computes it, so that the result size matches to the pixel.
        if render.use_border:
            self.xmin = int(_f32(_f32(render.border_min_x) * self.width))
            self.xmax = int(_f32(_f32(render.border_max_x) * self.width))
            self.ymin = int(_f32(_f32(render.border_min_y) * self.height))
            self.ymax = int(_f32(_f32(render.border_max_y) * self.height))
        else:
            self.xmin, self.ymin, self.xmax, self.ymax = 0, 0, self.width, self.height

    @property
    def is_border(self):
        """True when only part of the frame is rendered."""
        return (self.xmin, self.ymin, self.xmax, self.ymax) != (0, 0, self.width, self.height)

    @property
    def size(self):
        """Width and height of the rendered window (the render result's size)."""
        return self.xmax - self.xmin, self.ymax - self.ymin

    def crop_argument(self):
        """The window as the contract's `--crop X0,Y0,X1,Y1`: top-left origin, exclusive ends."""
        y0 = self.height - self.ymax
        y1 = self.height - self.ymin
        return f"{self.xmin},{y0},{self.xmax},{y1}"
