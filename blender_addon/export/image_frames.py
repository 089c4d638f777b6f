"""The frame of an image sequence an Image Texture node shows, as Blender picks it for Cycles:
the node's Image User (Start Frame, Offset, Frames, Cyclic) at the scene's frame, and the file
named by that frame (the file name's last run of digits replaced, zero-padded to its width)."""

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


class SequenceFrame:
    """One frame of an image sequence standing for the image in a graph (node_images.py writes
    its file's pixels); everything else is read from the image."""

    def __init__(self, image, image_user, scene_frame):
        self.image = image
        self.frame = user_frame(image_user, scene_frame)
        self.path = frame_path(image, self.frame)

    def __getattr__(self, name):
        return getattr(self.image, name)

    def as_pointer(self):
        """A key per image and frame (two nodes showing two frames are two images)."""
        return (self.image.as_pointer(), self.frame)

    def load(self):
        """A temporary image of the frame's file (the caller removes it), or None when missing."""
        if self.path is None or not os.path.isfile(self.path):
            return None
        temp = bpy.data.images.load(self.path, check_existing=False)
        temp.name = f"{self.image.name}_{self.frame}"
        temp.colorspace_settings.name = self.image.colorspace_settings.name
        temp.alpha_mode = self.image.alpha_mode
        return temp
