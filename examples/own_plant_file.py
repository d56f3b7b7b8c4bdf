"""Bring your own plant from a scenario file (``examples/own_plant.toml``).

Run: ``python examples/own_plant_file.py``
"""

from pathlib import Path

from adaptive_ftc import load_scenario
from adaptive_ftc.claims import evaluate_claims

scenario = load_scenario(Path(__file__).with_name("own_plant.toml"))

if __name__ == "__main__":
    result = scenario.run()
    frozen = scenario.run(adapt=False)
    print(f"{scenario.title}: {result.status}")
    print(f"RMS altitude error over 25-30 s: {float(result.rms_error(25, 30)[0]):.2e} m")
    for verdict in evaluate_claims(scenario.claims, result, frozen=frozen):
        print(f"{verdict.verdict}: {verdict.detail}")
        assert verdict.verdict == "PASS"
