"""Images that stand for one file of a Blender image: the frame of an image sequence an Image
Texture node shows, as Blender picks it for Cycles (the node's Image User: Start Frame, Offset,
Frames, Cyclic, at the scene's frame; the file name's last run of digits replaced by the frame,
zero-padded to its width), and each tile of a UDIM image (its `<UDIM>` or `<UVTILE>` token
replaced, as Cycles' image manager does)."""

import os
import re

import bpy


def user_frame(image_user, scene_frame):
    """The sequence frame `image_user` shows at `scene_frame` (Blender's image user frame
    calculation: counted from Start Frame, wrapped when Cyclic, held at the ends, then offset)."""
    length = image_user.frame_duration
    if length <= 0:
        return image_user.frame_offset
    frame = scene_frame - image_user.frame_start + 1
    if image_user.use_cyclic:
        frame %= length
        if frame == 0:
            frame = length
    frame = min(max(frame, 0), length)
    return frame + image_user.frame_offset


def frame_path(image, frame):
    """The absolute path of `image`'s file for `frame`, or None when its name has no digits."""
    path = bpy.path.abspath(image.filepath, library=image.library)
    folder, name = os.path.split(path)
    runs = list(re.finditer(r"\d+", name))
    if not runs:
        return None
    last = runs[-1]
    digits = f"{frame:0{len(last.group())}d}"
    return os.path.join(folder, name[:last.start()] + digits + name[last.end():])


def tile_path(image, number):
    """The absolute path of UDIM tile `number` of `image` (Blender's `<UDIM>` and `<UVTILE>`
    tokens), or None when its file path has neither."""
    path = bpy.path.abspath(image.filepath, library=image.library)
    u, v = (number - 1001) % 10, (number - 1001) // 10
    for token, value in (("<UDIM>", f"{number:04d}"), ("<UVTILE>", f"u{u + 1}_v{v + 1}")):
        if token in path:
            return path.replace(token, value)
    return None


class FileStandIn:
    """One file of a Blender image (a sequence's frame, a UDIM tile) standing for the image in a
    graph: node_images.py writes that file's pixels; everything else is read from the image."""

    def __init__(self, image, part, path, label):
        self.image = image
        self.part = part  # the frame or tile number
        self.path = path
        self.label = label  # "frame 12", "tile 1002": how warnings name the part

    def __getattr__(self, name):
        return getattr(self.image, name)

    def as_pointer(self):
        """A key per image and part (two nodes showing two frames are two images)."""
        return (self.image.as_pointer(), self.part)

    def load(self):
        """A temporary image of the file (the caller removes it), or None when it is missing."""
        if self.path is None or not os.path.isfile(self.path):
            return None
        temp = bpy.data.images.load(self.path, check_existing=False)
        temp.name = f"{self.image.name}_{self.part}"
        temp.colorspace_settings.name = self.image.colorspace_settings.name
        temp.alpha_mode = self.image.alpha_mode
        return temp


def sequence_frame(image, image_user, scene_frame):
    """The frame of sequence `image` that `image_user` shows at `scene_frame`."""
    frame = user_frame(image_user, scene_frame)
    return FileStandIn(image, frame, frame_path(image, frame), f"frame {frame}")


def udim_tiles(image):
    """Each tile of UDIM `image`, by tile number."""
    return [FileStandIn(image, t.number, tile_path(image, t.number), f"tile {t.number}") for t in image.tiles]
