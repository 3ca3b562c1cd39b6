"""Names: CANDIDE-3 animation units, MPEG-4 FAPs, ARKit blendshapes (``docs/STREAMS.md``),
and their resolution, case-insensitive as the server's JSONL reader does."""

from __future__ import annotations

from typing import Optional, Tuple, Union

from .errors import FrameError


# The Rust test tests/service/python_client.rs checks these tables against the library.

#: MPEG-4 FAP names, FAP n at index n - 1 (``core/src/mask/fap.rs``).
FAP_NAMES: Tuple[str, ...] = (
    "viseme", "expression", "open_jaw", "lower_t_midlip", "raise_b_midlip",
    "stretch_l_cornerlip", "stretch_r_cornerlip", "lower_t_lip_lm", "lower_t_lip_rm",
    "raise_b_lip_lm", "raise_b_lip_rm", "raise_l_cornerlip", "raise_r_cornerlip",
    "thrust_jaw", "shift_jaw", "push_b_lip", "push_t_lip", "depress_chin",
    "close_t_l_eyelid", "close_t_r_eyelid", "close_b_l_eyelid", "close_b_r_eyelid",
    "yaw_l_eyeball", "yaw_r_eyeball", "pitch_l_eyeball", "pitch_r_eyeball",
    "thrust_l_eyeball", "thrust_r_eyeball", "dilate_l_pupil", "dilate_r_pupil",
    "raise_l_i_eyebrow", "raise_r_i_eyebrow", "raise_l_m_eyebrow", "raise_r_m_eyebrow",
    "raise_l_o_eyebrow", "raise_r_o_eyebrow", "squeeze_l_eyebrow", "squeeze_r_eyebrow",
    "puff_l_cheek", "puff_r_cheek", "lift_l_cheek", "lift_r_cheek", "shift_tongue_tip",
    "raise_tongue_tip", "thrust_tongue_tip", "raise_tongue", "tongue_roll", "head_pitch",
    "head_yaw", "head_roll", "lower_t_midlip_o", "raise_b_midlip_o",
    "stretch_l_cornerlip_o", "stretch_r_cornerlip_o", "lower_t_lip_lm_o",
    "lower_t_lip_rm_o", "raise_b_lip_lm_o", "raise_b_lip_rm_o", "raise_l_cornerlip_o",
    "raise_r_cornerlip_o", "stretch_l_nose", "stretch_r_nose", "raise_nose", "bend_nose",
    "raise_l_ear", "raise_r_ear", "pull_l_ear", "pull_r_ear",
)


#: The 52 ARKit blendshapes in Apple's order; a name's index is what ``FWP2`` and ``FWP1`` carry.
ARKIT_BLENDSHAPES: Tuple[str, ...] = (
    "eyeBlinkLeft", "eyeLookDownLeft", "eyeLookInLeft", "eyeLookOutLeft", "eyeLookUpLeft",
    "eyeSquintLeft", "eyeWideLeft", "eyeBlinkRight", "eyeLookDownRight", "eyeLookInRight",
    "eyeLookOutRight", "eyeLookUpRight", "eyeSquintRight", "eyeWideRight", "jawForward",
    "jawLeft", "jawRight", "jawOpen", "mouthClose", "mouthFunnel", "mouthPucker",
    "mouthLeft", "mouthRight", "mouthSmileLeft", "mouthSmileRight", "mouthFrownLeft",
    "mouthFrownRight", "mouthDimpleLeft", "mouthDimpleRight", "mouthStretchLeft",
    "mouthStretchRight", "mouthRollLower", "mouthRollUpper", "mouthShrugLower",
    "mouthShrugUpper", "mouthPressLeft", "mouthPressRight", "mouthLowerDownLeft",
    "mouthLowerDownRight", "mouthUpperUpLeft", "mouthUpperUpRight", "browDownLeft",
    "browDownRight", "browInnerUp", "browOuterUpLeft", "browOuterUpRight", "cheekPuff",
    "cheekSquintLeft", "cheekSquintRight", "noseSneerLeft", "noseSneerRight", "tongueOut",
)


# CANDIDE-3.1.6's animation units in file order: 11 AUVs, then the 54 FAPs it implements.
_AUV_UNITS: Tuple[Tuple[str, int], ...] = (
    ("upper_lip_raiser", 0), ("jaw_drop", 11), ("lip_stretcher", 2), ("brow_lowerer", 3),
    ("lip_corner_depressor", 14), ("outer_brow_raiser", 5), ("eyes_closed", 6),
    ("lid_tightener", 7), ("nose_wrinkler", 8), ("lip_presser", 9), ("upper_lid_raiser", 10),
)


_FAP_UNITS: Tuple[int, ...] = tuple(range(3, 43)) + tuple(range(51, 65))


#: Every name each CANDIDE-3 animation unit answers to, its key first, by unit index
#: (``jaw_drop``, ``auv11``; ``fap3_open_jaw``, ``fap3``, ``open_jaw``).
ANIMATION_UNIT_NAMES: Tuple[Tuple[str, ...], ...] = tuple(
    [(key, "auv%d" % auv) for key, auv in _AUV_UNITS]
    + [("fap%d_%s" % (n, FAP_NAMES[n - 1]), "fap%d" % n, FAP_NAMES[n - 1]) for n in _FAP_UNITS]
)


#: The unit keys by index: what the unit index of ``FWP2`` and ``FWP1`` points at.
ANIMATION_UNITS: Tuple[str, ...] = tuple(names[0] for names in ANIMATION_UNIT_NAMES)


# The keys a JSONL frame object may have, and those FWP1 cannot carry (FWP2 carries
# head_translation too).
_FRAME_KEYS = ("seq", "t", "label", "au", "fap", "arkit", "head_rotation_rad",
               "head_translation", "controls", "viseme", "expression")


_JSON_ONLY_KEYS = ("head_translation", "controls", "expression")


#: Oculus/Meta's viseme names, in their (and MPEG-4's) order.
OCULUS_VISEMES: Tuple[str, ...] = ("sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR",
                                   "aa", "E", "ih", "oh", "ou")


_U64_MAX = (1 << 64) - 1


def _index_text(key: str) -> Optional[int]:
    text = key.strip()
    if text.isascii() and text.isdigit():
        return int(text)
    return None


def animation_unit_index(key: Union[str, int]) -> int:
    """The CANDIDE-3 animation unit index of ``key``: an index (``1`` or ``"1"``), a unit
    key (``jaw_drop``, ``fap3_open_jaw``) or an alias (``auv11``, ``fap3``, ``open_jaw``)."""
    count = len(ANIMATION_UNIT_NAMES)
    index = key if isinstance(key, int) and not isinstance(key, bool) else None
    if isinstance(key, str):
        index = _index_text(key)
        if index is None:
            lower = key.strip().lower()
            for i, names in enumerate(ANIMATION_UNIT_NAMES):
                if lower in names:
                    return i
    if index is not None and 0 <= index < count:
        return index
    raise FrameError("unknown animation unit %r; valid: an index 0..%d or one of %s"
                     % (key, count, ", ".join(ANIMATION_UNITS)))


def fap_number(key: Union[str, int]) -> int:
    """The FAP number of ``key``: a number 3..68 (``3`` or ``"3"``), a standard name
    (``open_jaw``), ``fap3`` or ``fap3_open_jaw``. FAPs 1 and 2 (viseme, expression) are
    not values: JSONL frames give them as ``viseme`` / ``expression``."""
    number: Optional[int] = None
    if isinstance(key, int) and not isinstance(key, bool):
        number = key
    elif isinstance(key, str):
        lower = key.strip().lower()
        number = _index_text(lower)
        if number is None and lower.startswith("fap"):
            rest = lower[3:]
            digits = len(rest) - len(rest.lstrip("0123456789"))
            if digits and 1 <= int(rest[:digits]) <= len(FAP_NAMES):
                n = int(rest[:digits])
                name = rest[digits:]
                if name == "" or name == "_" + FAP_NAMES[n - 1]:
                    number = n
        elif number is None and lower in FAP_NAMES:
            number = FAP_NAMES.index(lower) + 1
    if number is not None and 3 <= number <= len(FAP_NAMES):
        return number
    raise FrameError("unknown FAP %r; valid: a FAP number 3..=68 or a name: %s"
                     % (key, ", ".join(FAP_NAMES[2:])))


def arkit_index(key: Union[str, int]) -> int:
    """The ARKit blendshape index of ``key``: a name (``jawOpen``, any case) or 0..51."""
    index: Optional[int] = None
    if isinstance(key, int) and not isinstance(key, bool):
        index = key
    elif isinstance(key, str):
        index = _index_text(key)
        if index is None:
            lower = key.strip().lower()
            for i, name in enumerate(ARKIT_BLENDSHAPES):
                if name.lower() == lower:
                    return i
    if index is not None and 0 <= index < len(ARKIT_BLENDSHAPES):
        return index
    raise FrameError("unknown ARKit blendshape %r; valid: an index 0..51 or one of %s"
                     % (key, ", ".join(ARKIT_BLENDSHAPES)))
