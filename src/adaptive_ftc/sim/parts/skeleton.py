"""The skeleton of a generated loop's ``rhs`` and ``jump``: named hooks, in order, that the
parts fill (:meth:`Part.rhs <adaptive_ftc.sim.parts.base.Part.rhs>`,
:meth:`Part.jump <adaptive_ftc.sim.parts.base.Part.jump>`). A hook's lines are the parts'
lines in the parts' order; a hook no part fills is empty."""

from __future__ import annotations

import re
from collections.abc import Sequence

from adaptive_ftc.sim.layout import WORK
from adaptive_ftc.sim.parts.base import Build, Part

__all__ = [
    "COMMANDS_ONLY_TEST",
    "JUMP_HOOKS",
    "RHS_HOOKS",
    "jump_source",
    "rhs_lines",
    "used_views",
    "view",
]

#: the hooks of ``rhs(t, Y, ph, D, W, dY)``, in order (the comments say what each holds)
RHS_HOOKS: tuple[str, ...] = (
    "measure",  # sig[:nx]: what the controller measures (sensor)
    "reference",  # y_d and derivatives, once per time (reference)
    "errors",  # e, e', s per output (2.18) (sensor)
    "regressors",  # Pi and u0 = Pi^T theta (approximator)
    "control",  # the design's compensator (design law)
    # per actuator j (in the allocation's loop, 8 spaces deep):
    "allocate",  # the loop's head and acc = sum_i R_ij u0_i (allocation)
    "hold_command",  # between samples: the held command (sampler)
    "command",  # u[j] = acc (allocation)
    "delay_command",  # the command after the input delay (delay)
    "actuator_position",  # the actuator's position or clipped command (actuator)
    "failure",  # uf[j] (failures)
    # after the loop:
    "plant",  # the plant derivative (plant)
    "actuator_dynamics",  # actuator states' derivatives (actuator)
    "delay_dynamics",  # Pade states' derivatives (delay)
    "hold",  # held values' derivatives (sampler)
    "q",  # s' and the robust term q (s' part)
    "freeze",  # while adaptation is frozen: ... (design law)
    "frozen_hold",  # ... the held derivatives (sampler)
    "freeze_end",  # ... return (design law)
    "allocator_adapt",  # the adaptive allocator's estimate (allocation)
    "adapt_pre",  # the constraint-aware laws before the design's (constraint-aware)
    "adapt",  # the adaptive laws (design law)
    "adapt_post",  # ... and after them (constraint-aware)
    "after_adapt",  # between samples: the held derivatives (sampler)
)

#: the test of ``rhs``'s early return once the commands are known (before the ``plant`` hook):
#: a caller that wants the commands only passes a ``dY`` one longer than ``Y`` (the lean signals
#: of templates/record.py). Simulator-only: the C export drops it (export/controller_side.py).
COMMANDS_ONLY_TEST = "dY.size != Y.size"

#: the hooks of ``jump(t, Y, ph, D, W)``, in order
JUMP_HOOKS: tuple[str, ...] = (
    "jump_first",  # the first interval: the delay line holds the first command (delay)
    "jump_reading",  # at a sensor reading between samples: summed (decimation)
    "jump_sample",  # at a controller sample: ... (sampler)
    "jump_sample_shift",  # ... the delay line moves on (delay)
    "jump_sample_body",  # ... new command and derivatives, held (sampler)
    "jump_sample_end",  # ... the readings' sum emptied (decimation)
    "jump_actuator",  # actuators that become dynamic start at their command (actuator)
)


def _hooks(filled: list[dict[str, list[str]]], names: tuple[str, ...]) -> list[str]:
    unknown = {k for f in filled for k in f} - set(names)
    if unknown:
        raise ValueError(f"Unknown hook(s) {sorted(unknown)}; the hooks are {names}.")
    return [ln for name in names for f in filled for ln in f.get(name, ())]


def rhs_lines(b: Build, parts: Sequence[Part]) -> list[str]:
    """The lines of ``rhs`` (before :func:`used_views` drops the unused buffer views)."""
    filled = [part.rhs(b) for part in parts]
    override = [ln for f in filled for ln in f.pop("measure_override", ())]
    if override:  # a design that measures for itself (constraint-aware measurement filters)
        for f in filled:
            f.pop("measure", None)
        filled.insert(0, {"measure": override})
    label = f"{b.loop.plant.name} + {b.ctrl.code_label()}"
    head = [
        "@hot",
        "def rhs(t, Y, ph, D, W, dY):",
        f'    """Closed-loop derivative of {label} (in place)."""',
        f"    x = Y[0:{b.nx}]",
        "    c = D.c",
        *[view(name) for name in WORK],
    ]
    at = RHS_HOOKS.index("plant")
    # the commands are known before the plant's hook: a caller that wants only them (the lean
    # signals of a campaign's records, templates/record.py) passes a dY one longer than Y (a
    # part may write a derivative before this point: the constraint-aware command filter)
    commands_only = [
        f"    if {COMMANDS_ONLY_TEST}:  # the commands only (lean signals): no more derivatives",
        "        return",
    ]
    body = _hooks(filled, RHS_HOOKS)  # (checks the hooks' names)
    before = len(
        _hooks([{k: v for k, v in f.items() if k in RHS_HOOKS[:at]} for f in filled], RHS_HOOKS)
    )
    return head + body[:before] + commands_only + body[before:]


def jump_source(b: Build, parts: Sequence[Part]) -> str:
    """The text of ``jump`` (a Python no-op, not compiled, for a continuous loop)."""
    head = [
        "@hot",
        "def jump(t, Y, ph, D, W):",
        '    """State update at the start of interval ``ph`` (none: a continuous loop)."""',
    ]
    if any(part.jump_uses_scratch(b) for part in parts):
        head += [
            "    scratch = W[SCR:SCR + N_SCR]",
            "    misc = W[MISC:MISC + N_MISC]",
        ]
    lines = head + _hooks([part.jump(b) for part in parts], JUMP_HOOKS)
    if len(lines) == 3:  # a continuous loop: a Python no-op (for the scipy path)
        lines = [
            "CONTINUOUS = True  # no state update between intervals: jump is not compiled",
            "",
            "",
            *lines[1:],
            "    return",
        ]
    return "\n".join(lines)


def used_views(body: list[str]) -> list[str]:
    """``body`` without the work-array views it never uses (``wb = W[WB:WB + N_WB]``...):
    numba types and lowers every statement, used or not."""
    views = {view(name): name for name in WORK}
    rest = "\n".join(ln for ln in body if ln not in views)
    used = set(re.findall(r"[A-Za-z_]\w*", rest))  # one pass: this runs for every loop built
    return [ln for ln in body if ln not in views or views[ln] in used]


def view(name: str) -> str:
    """The line of the right-hand side that names the work-array buffer ``name``."""
    up = name.upper()
    return f"    {name} = W[{up}:{up} + N_{up}]"
