"""scripts/combo2_sign_study.py: the levers that swap one difference between the §4.4 and §2.3
constraint-aware laws on issue 25's second combination (docs/hardware.md, "Round 11b")."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

import adaptive_ftc.controllers.constraints as constraints
from adaptive_ftc.controllers.sign_estimation import SignEstimation

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))
import combo2_sign_study as study  # noqa: E402


@pytest.fixture
def restored(monkeypatch):
    """The script patches module constants and methods for its one run: restore them."""
    for name in ("C_INTEGRAL", "RHO_FACTOR", "RHO_FACTOR_INTEGRAL", "C_INTEGRAL_ZETA"):
        monkeypatch.setattr(constraints, name, getattr(constraints, name))
    monkeypatch.setattr(SignEstimation, "gains", SignEstimation.gains)
    monkeypatch.setattr(SignEstimation, "configuration", SignEstimation.configuration)


def _configuration(argv):
    ap_args = _parse(argv)
    study.patch(ap_args)
    loop, _ = study.build(ap_args)
    design = loop.controller.bound(loop)
    return design, design.configuration()


def _parse(argv):
    import argparse

    ns = argparse.Namespace(
        law="sign", failures=None, duration=None, seed=0, noise_off=False, growth=None,
        alpha1=None, alpha0=None, scale_x=None, slope_x=None, zeta=None,
        rho_factor_integral=None, c_integral=None, rho_factor=None,
    )  # fmt: skip
    for k, v in argv.items():
        setattr(ns, k, v)
    ns.failures = ns.failures or ns.law
    return ns


def test_the_session_14_law_is_the_two_levers_back(restored):
    design, cfg = _configuration({})
    assert design.rho_bound() == 1.0 and cfg.lam_factor > 2.0
    design, old = _configuration({"rho_factor_integral": 1.25, "zeta": 0.0})
    assert design.rho_bound() == 1.25 and old.lam_factor == 1.0
    assert old.scale == pytest.approx(cfg.scale / 1.25)
    assert old.error_integral == cfg.error_integral


def test_the_failure_scenario_is_swapped_and_the_run_prints_its_metrics(restored, capsys):
    args = _parse({"law": "direct", "failures": "sign"})
    loop, _ = study.build(args)
    assert [f.onset for f in loop.failures.failures] == [60.0, 80.0]
    assert study.main(["--law", "direct", "--failures", "sign", "--duration", "30"]) == 0
    out = capsys.readouterr().out
    assert "law direct, failures sign" in out and "error " in out and "fast " in out
