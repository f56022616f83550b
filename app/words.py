"""The names the inspector gives the contraction's parameters and methods: the panel's labels, which its status,
log and notices use too, so a person reads the same name everywhere; and a real parameter's text as its box shows
it and as a person types it."""
from __future__ import annotations

import math
import re

from skelcore.errors import ParameterError
from skelcore.params import AUTOMATIC, WEIGHT_MAX, ContractionParams

PARAMETER_LABELS = {"method": "Method", "k": "k", "wl0": "W_L0", "wh0": "W_H0", "sl": "s_L", "wl_max": "W_L cap",
                    "max_iterations": "Max iterations", "termination": "Termination", "hold_curves": "Hold curves",
                    "hold_inside": "Hold inside"}
SKELETON_LABELS = {"sample_radius": "Sample radius"}  # the skeleton's parameter in the More tab
PLAYBACK_LABELS = {"play_interval": "Play interval (s)"}
METHOD_LABELS = {"lbc": "LBC", "glskeleton": "GLSkeleton"}
METHODS_BY_LABEL = {shown: method for method, shown in METHOD_LABELS.items()}
# how skelcore.params names a refused value (a label's weight's box too, whose label can be negative), ...
_ENGINE_NAMING = re.compile(r"parameter ([\w-]+)=")
_RANGE = re.compile(r"^parameter ([\w-]+)=.*?: must be ")  # ... says what it must be
_VALUE = re.compile(r"^parameter ([\w-]+)=(.*?): ")  # ... and the value it read
_WEIGHT_NAME = re.compile(r"label_weight_(-?\d+)")


def label(name: str) -> str:
    """The panel's label of a ContractionParams or SkeletonParams field, of the Play interval or of a label's
    weight (`weight_name`); its own name when the panel lacks it."""
    weight = _WEIGHT_NAME.fullmatch(name)
    if weight:
        return f"the weight of label {weight.group(1)}"
    return PARAMETER_LABELS.get(name) or SKELETON_LABELS.get(name) or PLAYBACK_LABELS.get(name, name)


def weight_name(label_value: int) -> str:
    """The name a refusal of label `label_value`'s weight gives its box ("label_weight_3")."""
    return f"label_weight_{label_value}"


def value_text(name: str, value) -> str:
    """A parameter's value as the panel shows it."""
    if name == "method":
        return METHOD_LABELS.get(value, str(value))
    if isinstance(value, bool):
        return "on" if value else "off"
    if value is None:
        return "auto"
    return f"{value:g}" if isinstance(value, float) else str(value)


def assignments(params, names) -> str:
    """"s_L 2, W_H0 1.5": the named fields of `params` under their panel labels."""
    return ", ".join(f"{label(name)} {value_text(name, getattr(params, name))}" for name in names)


def number_text(value: float) -> str:
    """A real parameter as its text box shows it: the shortest form that reads back as the same float."""
    short = f"{value:g}"
    return short if float(short) == value else repr(float(value))


def typed_number(name: str, text) -> float:
    """The number a person typed into a parameter's text box ("1e-3", " 0.5 "); ParameterError (the engine's
    naming, which `refused` turns into the panel's) for anything else. Text boxes, not number boxes: viser's
    number box drops the "e" of 1e3 as it is typed and sends 13."""
    value = _typed(text)
    if not math.isfinite(value):  # 1e400 too: named as typed, not as the inf it reads as
        raise ParameterError(f"parameter {name}={_as_typed(text)}: must be a finite number (like 0.5 or 1e-3)")
    return value


def typed_whole_number(name: str, text) -> int:
    """A whole number typed into a parameter's text box ("12", "1e3"); ParameterError otherwise, as typed_number."""
    value = _typed(text)
    if not (math.isfinite(value) and value.is_integer()):
        raise ParameterError(f"parameter {name}={_as_typed(text)}: must be a whole number (like 12 or 1e3)")
    return int(value)


def typed_weight(label_value: int, text) -> float:
    """A label's contraction weight typed into its box ("2", "1e-2"); ParameterError otherwise, naming the box
    `weight_name(label_value)`, which `refused` words as the panel does."""
    value = _typed(text)
    if not 0 < value <= WEIGHT_MAX:  # NaN and infinity fail too
        raise ParameterError(f"parameter {weight_name(label_value)}={_as_typed(text)}: must be a positive number up "
                             f"to {WEIGHT_MAX:g} (like 2 or 1e-2)")
    return value


def _typed(text) -> float:
    """A text box's number; NaN when it holds none."""
    try:
        return float(str(text).strip())
    except ValueError:
        return math.nan


def _as_typed(text) -> str:
    typed = str(text).strip()
    return f"{typed!r:.30}" if typed else "(empty)"


def box_label(name: str) -> str:
    """The label of a parameter's box: a field with an automatic value says that 0 asks for it."""
    return f"{label(name)} (0 = auto)" if name in AUTOMATIC else label(name)


def refused_field(message: str) -> str | None:
    """The field a ParameterError's message names (the engine's name), if it names one."""
    named = _VALUE.match(message)
    return named.group(1) if named else None


def refused(message: str, typed: dict[str, str] | None = None) -> str:
    """A ParameterError's message with the engine's field names replaced by the panel's labels and the value read
    by the text of its box as typed (`typed`: field -> box text; "W_H0 = '1e3'", not the 1000.0 it read as); for a
    box that takes 0 for automatic, the range says so too (the engine's own range leaves 0 out). A comma in the
    text is taken for a decimal comma, which the boxes do not read: said."""
    named = _VALUE.match(message)
    if named and typed and named.group(1) in typed:
        text = typed[named.group(1)]
        message = message[:named.start(2)] + _as_typed(text) + message[named.end(2):]
        if "," in str(text):
            message += " (a point marks decimals: 0.5, not 0,5)"
    automatic = _RANGE.match(message)
    if automatic and automatic.group(1) in AUTOMATIC:
        message = message[:automatic.end()] + "0 (auto) or " + message[automatic.end():]
    return _ENGINE_NAMING.sub(lambda match: f"{label(match.group(1))} = ", message)


def capped_text(params) -> list[str]:
    """A line per starting weight typed above its cap (ContractionParams.starts_above_caps)."""
    return [f"{label(start)} = {getattr(params, start):g} is above its cap ({label(cap)} = {getattr(params, cap):g}): "
            f"the run starts at the cap, where a larger {label(start)} changes nothing"
            for start, cap in params.starts_above_caps()]


def weights_text(label_weights: dict[int, float]) -> str:
    """Label weights as the session log gives them ("1=0.5, 3=2")."""
    return ", ".join(f"{value}={weight:g}" for value, weight in sorted(label_weights.items())) or "none"


def start_text(params) -> str:
    """The parameters of a start (a ContractionParams), the two holds only where they differ from their defaults
    ("Hold inside on")."""
    switches = ("hold_curves", "hold_inside")
    changed = [name for name in switches if getattr(params, name) != getattr(ContractionParams(), name)]
    return assignments(params, [name for name in PARAMETER_LABELS if name not in switches] + changed)
