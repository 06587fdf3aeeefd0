"""The README is the user's manual: its option tables must match the code."""

import re
from pathlib import Path

from daq.serial_handlers.protocol_replay import describe_replay_options
from daq.sim import describe_options

README = (Path(__file__).resolve().parents[1] / "README.md").read_text()


def _option_names(table: str) -> list[str]:
    return re.findall(r"^\| `([a-z_0-9]+)` \|", table, flags=re.M)


def test_every_sim_and_replay_option_is_in_the_readme_with_its_current_row() -> None:
    rows = [row for table in (describe_options(), describe_replay_options())
            for row in table.splitlines() if row.startswith("| `")]
    assert len(_option_names(describe_options())) >= 30
    missing = [row for row in rows if row not in README]
    assert missing == []


def test_the_two_set_up_commands_are_the_first_commands() -> None:
    first_block = README.split("```sh", 1)[1].split("```", 1)[0]
    assert [line.split()[1] for line in first_block.strip().splitlines()] == ["demo", "test"]
