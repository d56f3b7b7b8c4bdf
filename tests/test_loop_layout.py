"""The generator as parts and its typed layout (issue 27): every state of a compiled loop has a
named place, the recorded columns are where :class:`RecordLayout` says, and nothing outside
the generator counts offsets into the flat arrays."""

from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from adaptive_ftc import load_scenario, simulate
from adaptive_ftc.allocation import AdaptiveAllocation
from adaptive_ftc.controllers import ConstraintAware
from adaptive_ftc.hardware import Actuators
from adaptive_ftc.sim.compose import assemble, source_of
from adaptive_ftc.sim.layout import RECORDS, Misc, RecordLayout
from adaptive_ftc.sim.parts import Build, Part, StateAllocator, parts, skeleton
from adaptive_ftc.sim.result import SimResult, signal_block

SRC = Path(__file__).resolve().parents[1] / "src" / "adaptive_ftc"


def _projected(loop):
    """``loop`` with its constraint-aware estimates projected on ``|theta| <= 10``."""
    ca = replace(loop.controller.constraint_aware, theta_max=10.0)
    return replace(loop, controller=replace(loop.controller, constraint_aware=ca))


def _loops():
    """Loops that use every optional part: actuators (first and second order), a digital
    controller, noisy sensors, an input delay, the filtered s', a MIMO plant, an adaptive
    allocator."""
    digital = load_scenario("hypersonic-direct-s1-digital").loop
    noisy = replace(load_scenario("hypersonic-direct-s1-noise").loop, sample_time=0.005)
    model = ConstraintAware.from_loop(noisy, decimation=True)  # the decimation filter
    decimated = replace(noisy, controller=replace(noisy.controller, constraint_aware=model))
    return {
        "actuators": (load_scenario("hypersonic-direct-s1-actuators").loop, "exact"),
        "projected": (_projected(load_scenario("hypersonic-direct-s1-actuators").loop), "exact"),
        "digital": (digital, "exact"),
        "noise": (load_scenario("hypersonic-direct-s1-noise").loop, "exact"),
        "mimo-filtered": (load_scenario("manipulator-mimo-s1").loop, "filtered"),
        "adaptive-allocator": (
            replace(load_scenario("manipulator-mimo-s1").loop, allocator=AdaptiveAllocation()),
            "exact",
        ),
        "digital-delay": (
            replace(digital, actuators=Actuators(delay=3 * digital.sample_time)),
            "exact",
        ),
        "digital-decimated": (decimated, "exact"),
        "second-order-delay": (
            replace(
                load_scenario("pendulum-direct").loop,
                actuators=Actuators(omega=30.0, zeta=0.7, delay=0.02),
            ),
            "exact",
        ),
    }


@pytest.mark.parametrize("name", list(_loops()))
def test_named_state_blocks_tile_the_state_vector_in_order(name):
    loop, sdot = _loops()[name]
    asm = assemble(loop, sdot=sdot)
    blocks = list(asm.layout.states.items())
    assert blocks[0] == ("plant", slice(0, loop.plant.n_states))
    for (_, a), (_, b) in zip(blocks, blocks[1:], strict=False):
        assert a.stop == b.start  # contiguous, in claim order
    assert blocks[-1][1].stop == asm.y0.size == asm.layout.n_states
    controller_stop = asm.layout.states["s_filter"].stop
    # the controller's states are the adaptive ones; every state after them has a label
    assert controller_stop - loop.plant.n_states == len(asm.adaptive_names)
    assert len(asm.extra_names) == asm.y0.size - controller_stop
    theta = asm.layout.states["theta"]
    assert theta.stop - theta.start == sum(s.stop - s.start for s in asm.theta_slices)
    if sdot == "filtered":
        s_filter = asm.layout.states["s_filter"]
        names = asm.adaptive_names[s_filter.start - loop.plant.n_states :]
        assert names[: loop.plant.n_outputs] == tuple(
            f"s_filter{i + 1}" for i in range(loop.plant.n_outputs)
        )


def test_recorded_columns_are_where_the_record_layout_says():
    """Truths the shared ``signals`` must satisfy column by column: y is the plant's position
    state, e = y_d - y, s = e' + lam e, the applied output equals the command before the first
    failure, the recorded gain of a design without one is 1 and u_f of the direct design 0."""
    sc = load_scenario("manipulator-mimo-s1")
    loop = replace(sc.loop, t_final=sc.loop.t0 + 0.5)
    r = simulate(loop, replace(sc.solver, record_dt=0.05))
    rec = RecordLayout(p=loop.plant.n_outputs, m=loop.plant.n_actuators)
    assert signal_block(loop, 3).shape == (3, rec.width)
    assert rec.width == sum(w.stop - w.start for _, w, _ in rec)
    pos = list(loop.plant.position_index)
    np.testing.assert_array_equal(r.y, r.states[:, pos])
    np.testing.assert_allclose(r.e, r.yd - r.y, rtol=0, atol=1e-12)
    lam = np.asarray(assemble(loop).data.c[assemble(loop).layout.params["lam"]])
    np.testing.assert_allclose(r.s, r.edot + lam * r.e, rtol=0, atol=1e-12)
    assert r.u_cmd.shape == r.u_applied.shape == (r.time.size, loop.plant.n_actuators)
    before = r.time < min(f.onset for f in loop.failures.failures)
    np.testing.assert_array_equal(r.u_applied[before], r.u_cmd[before])
    assert r.gain.ndim == r.u_f.ndim == r.control_gain.ndim == 1
    assert np.all(r.gain == 1.0) and np.all(r.u_f == 0.0)


def test_every_recorded_signal_is_a_result_field_or_the_s_prime_used():
    fields = set(SimResult.__dataclass_fields__)
    assert {name for name, _, _ in RECORDS} - fields == {"q", "sdot_used"}


def test_the_layout_answers_the_generators_flat_names_and_refuses_unknown_ones():
    asm = assemble(load_scenario("hypersonic-direct-s1").loop)
    assert asm.layout["c:lam"] == asm.layout.params["lam"]
    assert asm.layout["w:ref"] == asm.layout.work["ref"]
    assert asm.layout.misc(Misc.REF_VALID) == asm.layout.work["misc"].start + 3
    with pytest.raises(KeyError, match="No place 'w:nothing'"):
        asm.layout["w:nothing"]
    with pytest.raises(KeyError, match="No recorded signal 'ydot'"):
        asm.layout.records["ydot"]


def test_the_generated_text_names_the_misc_slots_of_the_layout():
    text = source_of(load_scenario("hypersonic-direct-s1-digital").loop)
    assert f"misc[{int(Misc.SAMPLING)}] = 1.0" in text
    assert f"misc[{int(Misc.REF_VALID)}] == 1.0 and misc[{int(Misc.REF_TIME)}] == t" in text
    assert f"misc[{int(Misc.GAIN)}] = 1.0" in text  # the direct design's recorded gain


def test_a_state_block_cannot_be_claimed_twice():
    states = StateAllocator()
    assert states.claim("plant", 2) == 0
    assert states.claim("theta", 3, controller=True) == 2
    assert states.claim("actuator_position", 2, ("position of a", "position of b")) == 5
    assert states.controller_stop == 5
    assert states.labels_after(5) == ("position of a", "position of b")
    with pytest.raises(ValueError, match="'theta' are claimed twice"):
        states.claim("theta", 1)


def test_a_part_filling_an_unknown_hook_is_refused_by_name():
    class Misplaced(Part):
        def rhs(self, b: Build) -> dict[str, list[str]]:
            return {"after_everything": ["    pass"]}

    loop = load_scenario("hypersonic-direct-s1").loop
    from adaptive_ftc.sim.compose import Generator

    b = Build(g=Generator(loop=loop, sdot="exact"), loop=loop, ctrl=loop.controller, sdot="exact")
    with pytest.raises(ValueError, match="after_everything"):
        skeleton.rhs_lines(b, [Misplaced()])


def test_every_hook_of_the_skeleton_is_filled_by_one_of_the_parts():
    """No dead hook: each hook of the skeleton is filled by some part for some loop."""
    from adaptive_ftc.sim.compose import Generator

    filled: set[str] = set()
    for loop, sdot in _loops().values():
        ctrl = loop.controller.bound(loop)
        b = Build(g=Generator(loop=loop, sdot=sdot), loop=loop, ctrl=ctrl, sdot=sdot)
        members = parts()
        for part in members:
            part.build(b)
        for part in members:
            filled |= {k for k, v in {**part.rhs(b), **part.jump(b)}.items() if v}
    assert set(skeleton.RHS_HOOKS) | set(skeleton.JUMP_HOOKS) == filled - {"measure_override"}


# code that reads a loop's flat arrays by counting: a literal misc slot, the old header
# constants, a literal offset into the signal table, result columns found by position
_ARITHMETIC = re.compile(r"misc\[\d|\b_I_[A-Z]+\b|D\.i\[s \+ \d|\b9 \* [pP]\b|\bmisc \+ \d")
#: the generator, its parts and its layout (and the shared signals, which writes the columns
#: in the order of layout.RECORDS: checked by the truths above)
_ALLOWED = ("sim/compose.py", "sim/layout.py", "sim/parts/", "sim/templates/record.py")


def test_no_index_arithmetic_on_the_loops_arrays_outside_the_generator():
    found = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if rel.startswith(_ALLOWED):
            continue
        for n, line in enumerate(path.read_text().splitlines(), 1):
            if _ARITHMETIC.search(line):
                found.append(f"{rel}:{n}: {line.strip()}")
    assert not found, "index arithmetic outside sim/layout.py:\n" + "\n".join(found)


def test_each_recorded_signal_is_owned_by_exactly_one_part():
    owned = [name for part in parts() for name in part.records]
    assert sorted(owned) == sorted(name for name, _, _ in RECORDS)
