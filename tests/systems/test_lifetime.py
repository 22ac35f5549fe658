"""rpod.systems.lifetime: callbacks that hold their system weakly, and a released diagram that
is freed with its last reference (pydrake 1.51 keeps it alive otherwise)."""

import gc
import weakref

import numpy as np
import pytest
from pydrake.common.value import AbstractValue
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, ValueProducer
from pydrake.systems.primitives import ConstantVectorSource

from rpod.systems.lifetime import LeafSystem, release_diagram, weak_method


class _Counter:
    def __init__(self):
        self.calls = 0

    def bump(self, step):
        self.calls += step
        return self.calls


def test_weak_method_calls_through_without_keeping_its_object():
    counter = _Counter()
    bump = weak_method(counter.bump)
    assert bump(2) == 2 and bump(3) == 5
    probe = weakref.ref(counter)
    del counter
    gc.collect()
    assert probe() is None
    with pytest.raises(RuntimeError, match="_Counter.bump: its system was freed"):
        bump(1)
    plain = np.sin
    assert weak_method(plain) is plain  # not a bound method: as it is


class _Everything(LeafSystem):
    """An input and output port, a periodic update and a cache entry kept as an attribute:
    each of them alone made a pydrake system immortal."""

    def __init__(self):
        super().__init__()
        self._u = self.DeclareVectorInputPort("u", 1)
        self._state = self.DeclareDiscreteState(1)
        self._doubled = self.DeclareCacheEntry(
            "doubled",
            ValueProducer(
                allocate=lambda: AbstractValue.Make(0.0), calc=weak_method(self._calc_doubled)
            ),
            prerequisites_of_calc={self.discrete_state_ticket(self._state)},
        )
        self.DeclareVectorOutputPort("y", 1, self._calc_y)
        self.DeclarePeriodicDiscreteUpdateEvent(0.1, 0.0, self._update)

    def _calc_doubled(self, context, value):
        value.set_value(2.0 * context.get_discrete_state(self._state).get_value()[0])

    def _calc_y(self, context, output):
        output.SetFromVector([self._doubled.Eval(context)])

    def _update(self, context, state):
        state.get_mutable_vector(self._state).SetFromVector(self._u.Eval(context))


def _run_once():
    builder = DiagramBuilder()
    source = builder.AddSystem(ConstantVectorSource([1.5]))
    system = builder.AddSystem(_Everything())
    builder.Connect(source.get_output_port(), system.get_input_port())
    diagram = builder.Build()
    simulator = Simulator(diagram)
    simulator.AdvanceTo(0.35)
    context = system.GetMyContextFromRoot(simulator.get_context())
    y = system.get_output_port().Eval(context)[0]
    probe = weakref.ref(system)
    release_diagram(diagram)
    return y, probe


def test_a_released_diagram_is_freed_with_its_python_systems():
    y, probe = _run_once()
    assert y == 3.0  # the system computed through its weak callbacks
    gc.collect()
    assert probe() is None
