"""Ship a trained policy as the package's ``learned`` agent.

    python scripts/ship_policy.py RUN_DIR

Copies ``RUN_DIR/policy.pt`` (``train.py --teacher planner``) to
``agents/learning/data/learned_policy.pt`` and writes its metadata (observation version and
geometry, episode rules, the training command, configuration and record) beside it as
``learned_policy.json``, readable without torch. ``make_agent("learned", env)`` then loads it.
"""

from __future__ import annotations

import argparse
import json
import pathlib
import shutil

from agents.learning.imitation import load_policy
from agents.learning.learned import SHIPPED_POLICY


def main(argv: list[str] | None = None) -> pathlib.Path:
    """Copy the run's policy into the package; returns the shipped path."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=pathlib.Path, help="a train.py --teacher output folder")
    args = parser.parse_args(argv)
    source = args.run / "policy.pt"
    policy = load_policy(source)  # refuses a file of another observation version
    SHIPPED_POLICY.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(source, SHIPPED_POLICY)
    meta = SHIPPED_POLICY.with_suffix(".json")
    meta.write_text(json.dumps(policy.meta, indent=1) + "\n")
    size = SHIPPED_POLICY.stat().st_size / 2**20
    print(f"shipped {source} as {SHIPPED_POLICY} ({size:.2f} MiB) and {meta}")
    return SHIPPED_POLICY


if __name__ == "__main__":
    main()
