"""The one exception type the add-on reports to the user as a plain message."""


class CausticError(Exception):
    """A failure with a message fit for Blender's report (no traceback needed)."""
