"""One name per option across the `ident` and `daq` commands; old spellings are hidden aliases."""

from __future__ import annotations

import argparse
from collections import defaultdict

import pytest

from daq.cli import build_parser as daq_parser
from ident.cli import build_parser as ident_parser
from ident.cli import main as ident_main


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _visible_options() -> dict[str, set[str]]:
    """dest -> every visible long option spelling that sets it, over all subcommands."""
    names: dict[str, set[str]] = defaultdict(set)
    for parser in (ident_parser(), daq_parser()):
        for sub in _subcommands(parser).values():
            for action in sub._actions:
                if action.help == argparse.SUPPRESS:
                    continue
                for spelling in action.option_strings:
                    if spelling.startswith("--") and spelling != "--help":
                        names[action.dest].add(spelling)
    return names


def test_each_setting_has_one_option_name_in_every_command() -> None:
    clashes = {dest: sorted(spellings) for dest, spellings in _visible_options().items() if len(spellings) > 1}
    assert not clashes, f"one setting, several option names across commands: {clashes}"


def test_scan_sees_the_options_it_checks() -> None:
    options = _visible_options()
    assert options["step_m"] == {"--step-m"} and options["rate_hz"] == {"--rate-hz"}
    assert options["runs_dir"] == {"--runs-dir"}


@pytest.mark.parametrize(("command", "old", "new", "dest"), [
    ("diagnose", "--step", "--step-m", "step_m"),
    ("fit", "--rate", "--rate-hz", "rate_hz"),
])
def test_old_spellings_still_work_and_say_the_new_name(command: str, old: str, new: str, dest: str,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    args = ident_parser().parse_args([command, "run.csv", old, "0.25"])
    assert getattr(args, dest) == 0.25
    assert f"{old} is deprecated, use {new}" in capsys.readouterr().err
    assert getattr(ident_parser().parse_args([command, "run.csv", new, "0.5"]), dest) == 0.5
    with pytest.raises(SystemExit):
        ident_main([command, "--help"])
    shown = capsys.readouterr().out
    assert new in shown and f"{old} " not in shown.replace(new, "")


def test_release_picks_a_release_by_its_number_in_fit_and_diagnose() -> None:
    # issue 10: `--release K` is the K-th release of the record (the time is `--release-s`)
    for command in ("fit", "diagnose"):
        args = ident_parser().parse_args([command, "run.csv", "--release", "2"])
        assert args.release_number == 2 and args.all is False
        assert ident_parser().parse_args([command, "run.csv", "--all"]).all is True
        with pytest.raises(SystemExit):
            ident_parser().parse_args([command, "run.csv", "--release", "0.25"])


@pytest.mark.parametrize("command", ["fit", "diagnose", "releases", "report"])
def test_position_columns_given_one_option_each_are_all_kept(command: str) -> None:
    # `--pos "Encoder 1 Pos" --pos "Encoder 2 Pos"` kept only the last (argparse's nargs="+"
    # stores): a two-cart record was diagnosed as one cart, with nothing said
    sub = _subcommands(ident_parser())[command]
    extra = ["-o", "out"] if command == "report" else []
    repeated = sub.parse_args(["run.txt", *extra, "--pos", "Encoder 1 Pos", "--pos", "Encoder 2 Pos"])
    listed = sub.parse_args(["run.txt", *extra, "--pos", "Encoder 1 Pos", "Encoder 2 Pos"])
    assert repeated.pos_cols == listed.pos_cols == ["Encoder 1 Pos", "Encoder 2 Pos"]
    assert sub.parse_args(["run.txt", *extra]).pos_cols is None
