"""The sensed signals: one bundle that every guidance, monitoring and drawing system reads.

Owns: the layout of the `sensed` vector port, the one place it is declared
(`declare_sensed_input`) and read (`Sensed.from_vector`), and `sensed_vector` to build one.
Does not own: where the signals come from. Today rpod.diagrams multiplexes the truth's outputs
into the bundle; a navigation filter will output the same vector and take the truth's place,
with no change to the systems that read it.

Layout (33 numbers, in this order):

    relative_state_L (6)  [p_LC_L, v_LC_L]: chaser from the target, in LVLH (v seen in L)
    q_IL             (4)  LVLH attitude (w, x, y, z)
    w_IL_L           (3)  LVLH angular velocity, in L
    target_attitude  (7)  [q_IT, w_IT_T]
    chaser_attitude  (7)  [q_IC, w_IC_C]
    target_state_I   (6)  [p_IT_I, v_IT_I]: the target's orbit in ECI (a navigation filter has
                          it from the chaser's own absolute fix and the relative state); the
                          online linearisation of paper 004 Sec. 4.4 starts from it
"""

import dataclasses

import numpy as np

SENSED_FIELDS = (
    ("relative_state_L", 6),
    ("q_IL", 4),
    ("w_IL_L", 3),
    ("target_attitude", 7),
    ("chaser_attitude", 7),
    ("target_state_I", 6),
)
SENSED_SIZE = sum(size for _, size in SENSED_FIELDS)
SENSED_PORT = "sensed"


_SLICES = {}
_start = 0
for _name, _size in SENSED_FIELDS:
    _SLICES[_name] = slice(_start, _start + _size)
    _start += _size


@dataclasses.dataclass(frozen=True)
class Sensed:
    """One sample of the bundle with its parts by name (views into `vector`, no copies)."""

    vector: np.ndarray

    @classmethod
    def from_vector(cls, vector) -> "Sensed":
        """Wraps a `sensed` port value (33,)."""
        return cls(np.asarray(vector))

    relative_state_L = property(lambda self: self.vector[_SLICES["relative_state_L"]])
    p_LC_L = property(lambda self: self.vector[0:3])
    v_LC_L = property(lambda self: self.vector[3:6])
    q_IL = property(lambda self: self.vector[_SLICES["q_IL"]])
    w_IL_L = property(lambda self: self.vector[_SLICES["w_IL_L"]])
    target_attitude = property(lambda self: self.vector[_SLICES["target_attitude"]])

    def with_target_attitude(self, q_IT, w_IT_T) -> "Sensed":
        """A copy whose target attitude and rate are these (e.g. a body-fixed frame's)."""
        vector = np.array(self.vector, dtype=float)
        vector[_SLICES["target_attitude"]] = np.concatenate([q_IT, w_IT_T])
        return Sensed(vector)

    def with_chaser_attitude(self, q_IC, w_IC_C) -> "Sensed":
        """A copy whose chaser attitude and rate are these (e.g. a body-fixed frame's)."""
        vector = np.array(self.vector, dtype=float)
        vector[_SLICES["chaser_attitude"]] = np.concatenate([q_IC, w_IC_C])
        return Sensed(vector)

    q_IT = property(lambda self: self.vector[13:17])
    w_IT_T = property(lambda self: self.vector[17:20])
    chaser_attitude = property(lambda self: self.vector[_SLICES["chaser_attitude"]])
    q_IC = property(lambda self: self.vector[20:24])
    w_IC_C = property(lambda self: self.vector[24:27])
    target_state_I = property(lambda self: self.vector[_SLICES["target_state_I"]])


def sensed_vector(
    relative_state_L, q_IL, w_IL_L, target_attitude, chaser_attitude, target_state_I=None
) -> np.ndarray:
    """The `sensed` vector (33) from its parts, in the layout of the module docstring.

    target_state_I may be left out by a caller whose systems do not read it: it is then NaN
    (unknown), never a made-up orbit.
    """
    if target_state_I is None:
        target_state_I = np.full(6, np.nan)
    parts = (relative_state_L, q_IL, w_IL_L, target_attitude, chaser_attitude, target_state_I)
    for (name, size), part in zip(SENSED_FIELDS, parts):
        if np.shape(part) != (size,):
            raise ValueError(f"{name}: expected {size} numbers, got shape {np.shape(part)}")
    return np.concatenate([np.asarray(part, dtype=float) for part in parts])


def declare_sensed_input(system):
    """Declares the `sensed` vector input port (33) on a LeafSystem; returns the port."""
    return system.DeclareVectorInputPort(SENSED_PORT, SENSED_SIZE)
