"""Constant folding of a linked float input: the value a chain of Value, Math and Reroute nodes
over unlinked inputs gives it, as Cycles' constant folding (`intern/cycles/scene/constant_fold.cpp`)
turns such a chain into one number before rendering. Used where Caustic takes a number but
Blender allows a link (a volume shader's Density): a chain that folds is exported as its value;
anything else (a texture, an attribute, a geometry input) does not fold and keeps the caller's
warning."""

import math


def _safe_divide(a, b):
    return a / b if b != 0.0 else 0.0


def _safe_power(a, b):
    # Cycles' safe_powf: a negative base with a non-integer exponent gives 0.
    if a < 0.0 and b != math.floor(b):
        return 0.0
    try:
        return math.pow(a, b)
    except (OverflowError, ValueError, ZeroDivisionError):
        return 0.0


def _safe_modulo(a, b):
    # Cycles' safe_modulo: fmod, 0 for b = 0.
    return math.fmod(a, b) if b != 0.0 else 0.0


# Math node operations on (a, b, c) as Cycles' svm_math computes them (the common ones).
_MATH = {
    "ADD": lambda a, b, c: a + b,
    "SUBTRACT": lambda a, b, c: a - b,
    "MULTIPLY": lambda a, b, c: a * b,
    "DIVIDE": lambda a, b, c: _safe_divide(a, b),
    "MULTIPLY_ADD": lambda a, b, c: a * b + c,
    "POWER": lambda a, b, c: _safe_power(a, b),
    "MINIMUM": lambda a, b, c: min(a, b),
    "MAXIMUM": lambda a, b, c: max(a, b),
    "ABSOLUTE": lambda a, b, c: abs(a),
    "MODULO": lambda a, b, c: _safe_modulo(a, b),
    "SQRT": lambda a, b, c: math.sqrt(a) if a > 0.0 else 0.0,
}

# Links followed at most: a longer chain (or a cycle, which Blender forbids) does not fold.
_MAX_DEPTH = 64


def folded_float(sock, depth=0):
    """The constant a float input takes, or None when its link does not fold."""
    if not sock.is_linked:
        value = sock.default_value
        try:
            return float(value)
        except TypeError:  # a colour or vector: Cycles converts colour to float by its average
            return None
    if depth > _MAX_DEPTH:
        return None
    link = next((k for k in sock.links if k.is_valid and not k.is_muted), None)
    if link is None:
        return float(sock.default_value) if not hasattr(sock.default_value, "__len__") else None
    node, out = link.from_node, link.from_socket
    if node.mute:
        return None
    if node.type == "REROUTE":
        return folded_float(node.inputs[0], depth + 1)
    if node.type == "VALUE":
        return float(out.default_value)
    if node.type == "MATH":
        op = _MATH.get(node.operation)
        if op is None:
            return None
        inputs = [folded_float(s, depth + 1) for s in node.inputs[:3]]
        if any(v is None for v in inputs):
            return None
        result = op(*inputs)
        if node.use_clamp:
            result = min(max(result, 0.0), 1.0)
        return float(result)
    return None
