"""Python systems that die with their diagram: rpod's way round pydrake's immortal leaf systems.

Owns: `LeafSystem` (pydrake's, its callbacks holding their system weakly), `weak_method`, and
`release_diagram`, which a run calls once it is over. Does not own: building or running
diagrams (rpod.diagrams).

Why. On drake 1.51 (the newest on PyPI), a diagram with a Python LeafSystem in it is never freed:
each `simulate()` of `hold_point` left 2.7 MB behind (benchmarks/results/memory.md).
Two things keep it alive, each a cycle Python's collector cannot break:
1. A bound method given as a callback (an output port's calc, an event's handler, a cache
   entry's producer) is kept by the C++ system and keeps its Python system alive (drake#22515,
   #23930, #24162; drake#24852 fixes vector output ports only, after 1.51).
2. The `ref_cycle` peer sets pydrake keeps between a system, its ports, its builder and its
   diagram (`_pydrake_internal_ref_cycle_peers`) are not collected either: a LeafSystem with
   one input port and nothing else is never freed. Nor is a system that keeps its own
   `CacheEntry` as an attribute (the entry keeps the system alive from C++, `keep_alive`).
(1) is avoided by giving C++ a function that holds the method weakly (`weak_method`; this
module's `LeafSystem` does it for every bound method of the system it is given); a lambda or
closure that captures `self` would bring it back, so rpod's systems pass bound methods (or
lambdas that capture what they read, a state index). (2) is undone by `release_diagram`, which
empties those sets (and drops the cache-entry attributes) once the run is over, after which
reference counting frees the diagram, its systems and their C++ state when the last Python
reference goes. Neither changes what a system computes.
"""

from __future__ import annotations

import weakref

from pydrake.systems.framework import CacheEntry, Diagram
from pydrake.systems.framework import LeafSystem as _DrakeLeafSystem

PEERS = "_pydrake_internal_ref_cycle_peers"  # pydrake's attribute holding an object's peers


def weak_method(method):
    """A function calling `method` (a bound method) without keeping its object alive.

    Anything else is returned as it is. Calling it after the object was freed raises
    RuntimeError, which cannot happen while the object's diagram runs (the diagram holds it).
    """
    if getattr(method, "__self__", None) is None or not hasattr(method, "__func__"):
        return method
    # A plain weak reference and the function: cheaper per call than weakref.WeakMethod (a
    # Python-level __call__), and these run at every output evaluation and integrator stage.
    ref, function = weakref.ref(method.__self__), method.__func__

    def call(*args):
        owner = ref()
        if owner is None:
            raise RuntimeError(f"{function.__qualname__}: its system was freed before its diagram")
        return function(owner, *args)

    return call


def _weakened(args, kwargs):
    return (
        tuple(weak_method(value) for value in args),
        {key: weak_method(value) for key, value in kwargs.items()},
    )


# pydrake's LeafSystem methods that hand a callback to C++.
CALLBACK_DECLARATIONS = (
    "DeclareVectorOutputPort",
    "DeclareAbstractOutputPort",
    "DeclarePeriodicDiscreteUpdateEvent",
    "DeclarePeriodicUnrestrictedUpdateEvent",
    "DeclarePeriodicPublishEvent",
    "DeclareInitializationPublishEvent",
    "DeclareInitializationDiscreteUpdateEvent",
    "DeclareInitializationUnrestrictedUpdateEvent",
    "DeclarePerStepPublishEvent",
    "DeclareForcedPublishEvent",
)


class LeafSystem(_DrakeLeafSystem):
    """pydrake's LeafSystem whose declared callbacks hold the system weakly (module docstring).

    Every bound method passed to one of CALLBACK_DECLARATIONS goes to C++ through
    `weak_method`; their signatures and behaviour are pydrake's.
    """


def _weakening(name: str):
    def declare(self, *args, **kwargs):
        args, kwargs = _weakened(args, kwargs)
        return getattr(_DrakeLeafSystem, name)(self, *args, **kwargs)

    declare.__name__ = declare.__qualname__ = name
    declare.__doc__ = f"pydrake's {name}, a bound method passed on through `weak_method`."
    return declare


for _name in CALLBACK_DECLARATIONS:
    setattr(LeafSystem, _name, _weakening(_name))


def release_diagram(*roots) -> int:
    """Empties pydrake's peer sets reachable from roots (a diagram, its builder, systems), so
    that the diagram and everything in it are freed when their last Python reference goes.

    Call it only when the diagram will not be simulated again: while it is referenced it
    stays alive and usable, but nothing is kept alive on its account any more. Returns how
    many objects' peer sets were emptied.
    """
    stack, seen, kept, released = list(roots), set(), [], 0
    while stack:
        item = stack.pop()
        if id(item) in seen:
            continue
        seen.add(id(item))
        kept.append(item)  # alive until the walk ends, so that no id is reused meanwhile
        if isinstance(item, Diagram):
            stack.extend(item.GetSystems())
        attributes = getattr(item, "__dict__", {})
        for name in [key for key, value in attributes.items() if isinstance(value, CacheEntry)]:
            del attributes[name]  # kept alive by its system from C++ (keep_alive), and it by it
        peers = attributes.pop(PEERS, None)
        if peers:
            released += 1
            stack.extend(peers)
    return released
