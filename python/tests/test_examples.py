"""The Python examples under examples/python/ run (those that need no extra package)."""

import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]


def run_example(*args):
    return subprocess.run(
        [sys.executable, str(ROOT / "examples" / "python" / args[0]), *args[1:]],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )


def test_the_random_policy_loop_runs_a_season_of_any_model():
    done = run_example("random_policy.py", "models/lettuce.ghm", "--days", "1", "--episodes", "2")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("episode 0: return ") and lines[0].endswith(" over 48 steps")
    assert lines[-1].startswith("mean return ")


def test_a_plant_driven_out_of_range_stops_its_episode_with_ghms_message():
    # Random inputs run the CSTR away within a day: the episode stops with the step and
    # the model line, and the loop carries on.
    done = run_example("random_policy.py", "models/cstr.ghm", "--days", "1", "--episodes", "1")
    assert done.returncode == 0, done.stderr
    assert "stopped: step " in done.stdout and "models/cstr.ghm:" in done.stdout, done.stdout
