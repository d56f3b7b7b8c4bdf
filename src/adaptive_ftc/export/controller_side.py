"""The controller side of a generated closed-loop right-hand side (for the C export).

The simulator's ``rhs`` (:mod:`adaptive_ftc.sim.compose`) computes, in one function, the
controller (measurements, errors, regressors, control law, allocation, ``s'`` filter, adaptive
laws) and the plant side (failures, actuators, the plant's equations). At a controller sample
(``misc[Misc.SAMPLING] == 1``) the controller's part is what a deployed controller runs: this
module keeps it, statement by statement, from the parsed ``rhs``.

The designer's model of the plant (``nominal_dynamics`` with ``nominal_params``: the healthy
plant's equations and nominal parameters, which the constraint-aware MIMO law's model
feedforward evaluates on the reference read ahead, in its own work buffer ``wb``) is the
controller's: it is kept, and the C carries the plant's equations and parameters for it. What
needs the true plant (its failures, the actuators, the plant-side buffers ``uf`` and ``xdot``)
is not.
"""

from __future__ import annotations

import ast

from adaptive_ftc.errors import ConfigurationError
from adaptive_ftc.sim.layout import Misc
from adaptive_ftc.sim.parts.decimation import MEASURED

__all__ = ["controller_side"]

#: the names of the plant side of a generated right-hand side: a statement that uses one is
#: not part of the controller (failures, actuator dynamics and delays, the plant's equations)
_PLANT_SIDE = frozenset(
    {
        "uf",
        "xdot",
        "plant_dynamics",
        "plant_params",
        "instance",
        "failure_cached",
        "failure",
        "act",
        "delayed",
        "fc",
        "call_pattern",
        "ph",
    }
)


def controller_side(stmts: list, ny: int, tainted: set | None = None) -> list:
    """The controller's statements of a generated ``rhs`` body (see the module docstring).

    A statement that uses a name of the plant side is dropped, and the names it assigns join
    the plant side for the statements after it (``tau = act(...)`` then ``if tau > 0``).
    """
    tainted = set(_PLANT_SIDE) if tainted is None else tainted
    out = []
    for st in stmts:
        st = _Fold().visit(st)
        if st is None:
            continue
        if isinstance(st, ast.If):
            if isinstance(st.test, ast.Constant):  # folded: misc[Misc.SAMPLING] (at a sample) is 1
                out += controller_side(st.body if st.test.value else st.orelse, ny, tainted)
                continue
            if _calls(st, "reference"):  # the reference cache: r is an input (in W)
                out += controller_side(st.body, ny, tainted)
                continue
            if _uses(st.test, tainted):
                _drop(st, tainted)
                continue
            body, orelse = (
                controller_side(st.body, ny, tainted),
                controller_side(st.orelse, ny, tainted),
            )
            if not body and not orelse:
                continue
            st.body, st.orelse = body or [ast.Pass()], orelse
            out.append(st)
            continue
        if isinstance(st, ast.For):
            if _writes_only_beyond(st, ny):  # held states of the simulator: not the controller's
                continue
            if _uses(st.iter, tainted):
                _drop(st, tainted)
                continue
            body = controller_side(st.body, ny, tainted)
            if not body:
                continue
            st.body = body
            out.append(st)
            continue
        if isinstance(st, ast.Expr) and _calls_reference_into_ref(st):
            continue
        if _uses(st, tainted):
            _drop(st, tainted)
            continue
        for name in _assigned(st):  # assigned by the controller again: its own value
            tainted.discard(name)
        out.append(st)
    return out


#: the controller's signals: a plant-side statement must not write them
_CONTROLLER_SIGNALS = frozenset({"u", "u0", "q", "sig", "phi", "mu", "wb", "ref"})


def _drop(st, tainted: set) -> None:
    """Drop the plant-side statement ``st``: what it assigns is plant side from here on."""
    for node in ast.walk(st):
        if isinstance(node, (ast.Assign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for t in targets:
                if (
                    isinstance(t, ast.Subscript)
                    and isinstance(t.value, ast.Name)
                    and t.value.id in _CONTROLLER_SIGNALS
                ):
                    raise ConfigurationError(
                        f"Cannot export to C: the controller's signal `{t.value.id}` is written "
                        f"from the plant side in `{ast.unparse(node)[:80]}` (generated loop "
                        f"module, line {getattr(node, 'lineno', '?')}): the controller would "
                        "need the plant's model or its failures, which a deployed controller "
                        "does not have (designs that invert the true plant, such as the "
                        "nominal-inverse and oracle baselines, are not exported): export "
                        "the scenario's adaptive design instead (the constraint-aware MIMO "
                        "law's model feedforward is exported: it evaluates the healthy model, "
                        "`nominal_dynamics`, not the plant side)."
                    )
    tainted.update(_assigned(st))


def _assigned(st) -> set[str]:
    """Plain names assigned anywhere in ``st``."""
    names = set()
    for node in ast.walk(st):
        if isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
            names.add(node.id)
    return names


class _Fold(ast.NodeTransformer):
    """``misc[Misc.SAMPLING]`` (computing a sample) is 1; ``meas(...)`` (the sensors' offset)
    is 0: the measurement ``y`` already holds it; ``measured(x, Y, ph, i, D)`` (the decimation
    filter's mean) is ``x[i]``: the C's ``x`` holds the mean; comparisons of constants are
    folded."""

    def visit_Subscript(self, node):
        self.generic_visit(node)
        if (
            isinstance(node.ctx, ast.Load)
            and isinstance(node.value, ast.Name)
            and node.value.id == "misc"
            and isinstance(node.slice, ast.Constant)
            and node.slice.value == Misc.SAMPLING
        ):
            return ast.copy_location(ast.Constant(1.0), node)
        return node

    def visit_Call(self, node):
        self.generic_visit(node)
        if isinstance(node.func, ast.Name) and node.func.id == "meas":
            return ast.copy_location(ast.Constant(0.0), node)
        if isinstance(node.func, ast.Name) and node.func.id == MEASURED and len(node.args) == 5:
            # the decimation filter's mean of the period's readings, ``measured(x, Y, ph, i,
            # D)``: the C's ``x`` already holds that mean (``<prefix>_step`` puts the mean of
            # the readings given to ``<prefix>_read`` there), so it reads ``x[i]``
            x, _, _, i, _ = node.args
            read = ast.Subscript(value=x, slice=i, ctx=ast.Load())
            return ast.copy_location(read, node)
        return node

    def visit_Compare(self, node):
        self.generic_visit(node)
        if (
            len(node.ops) == 1
            and isinstance(node.left, ast.Constant)
            and isinstance(node.comparators[0], ast.Constant)
        ):
            a, b = node.left.value, node.comparators[0].value
            ops = {ast.Eq: a == b, ast.NotEq: a != b, ast.Lt: a < b, ast.Gt: a > b}
            if type(node.ops[0]) in ops:
                return ast.copy_location(ast.Constant(bool(ops[type(node.ops[0])])), node)
        return node


def _uses(node, names) -> bool:
    return any(isinstance(n, ast.Name) and n.id in names for n in ast.walk(node))


def _calls(node, name: str) -> bool:
    return any(
        isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id == name
        for n in ast.walk(node)
    )


def _calls_reference_into_ref(st: ast.Expr) -> bool:
    """``reference(t, c, ref)``: the reference at the sample, the C's input ``r``. Another
    call (the model feedforward's ``reference(t + lead, c, wb[...])``, read ahead) is the
    controller's own: it stays, and the C computes the scenario's reference there."""
    call = st.value
    return (
        isinstance(call, ast.Call)
        and isinstance(call.func, ast.Name)
        and call.func.id == "reference"
        and len(call.args) == 3
        and isinstance(call.args[2], ast.Name)
        and call.args[2].id == "ref"
    )


def _writes_only_beyond(st: ast.For, ny: int) -> bool:
    """``for i in range(A, B): dY[i] = ...`` with ``A >= ny`` (the simulator's held values)."""
    it = st.iter
    if not (isinstance(it, ast.Call) and len(it.args) >= 2):
        return False
    lo = it.args[0]
    if not (isinstance(lo, ast.Constant) and isinstance(lo.value, int) and lo.value >= ny):
        return False
    return all(
        isinstance(s, ast.Assign)
        and isinstance(s.targets[0], ast.Subscript)
        and isinstance(s.targets[0].value, ast.Name)
        and s.targets[0].value.id == "dY"
        for s in st.body
    )
