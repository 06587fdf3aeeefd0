import pytest

from schemas import SchemaError, keys


def test_keys_are_built_from_checked_names() -> None:
    assert keys.samples("bench1") == "cartlab/bench1/samples"
    assert keys.run_finished("b", "r-20261122-001") == "cartlab/b/runs/r-20261122-001/finished"
    assert keys.daq_query("b", "zero") == "cartlab/b/daq/zero"
    assert keys.parse_run_key("cartlab/b/runs/r1/fit") == ("b", "r1", "fit")


@pytest.mark.parametrize("bad", ["", ".", "..", "a/b", "*", "**", "a b", "-x", "x" * 129, "é"])
def test_bad_names_are_rejected_with_what_was_expected(bad: str) -> None:
    with pytest.raises(SchemaError, match="expected 1-128 characters"):
        keys.samples(bad)


def test_unknown_query_is_rejected() -> None:
    with pytest.raises(SchemaError, match="expected one of status"):
        keys.daq_query("b", "reboot")  # type: ignore[arg-type]


@pytest.mark.parametrize("key", ["cartlab/b/runs/r1", "other/b/runs/r1/fit", "cartlab/b/run/r1/fit",
                                 "cartlab/b/runs/../fit"])
def test_parse_run_key_rejects_foreign_keys(key: str) -> None:
    with pytest.raises(SchemaError):
        keys.parse_run_key(key)
