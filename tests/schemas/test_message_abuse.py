"""Malformed, wrong-typed, extra-field and oversized JSON for every `schemas` record.

Every record that crosses a boundary is parsed with `Record.from_json_bytes`; whatever the
bytes, the only exception allowed out is `SchemaError`, and its message names the record
and what was expected. Records are found by walking the `schemas` package, so a record
added later is covered without touching this file.
"""

from __future__ import annotations

import importlib
import inspect
import json
import pkgutil
import types
import typing
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import BaseModel, ValidationError

import schemas
from schemas import MAX_PAYLOAD_BYTES, Record, SchemaError


def _all_records() -> list[type[Record]]:
    found: dict[str, type[Record]] = {}
    for info in pkgutil.iter_modules(schemas.__path__):
        module = importlib.import_module(f"schemas.{info.name}")
        for name, obj in vars(module).items():
            if inspect.isclass(obj) and issubclass(obj, Record) and obj is not Record \
                    and obj.__module__ == module.__name__:
                found[f"{module.__name__}.{name}"] = obj
    return [found[k] for k in sorted(found)]


RECORDS = _all_records()
#: Values for fields whose validators reject the generic minimal value.
OVERRIDES: dict[str, dict[str, Any]] = {
    "TransferFunctionRec": {"num": [1.0], "den": [1.0, 2.0, 3.0]},
}


def _minimal_value(annotation: Any) -> Any:
    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin in (typing.Union, types.UnionType):
        return None if type(None) in args else _minimal_value(args[0])
    if origin is typing.Literal:
        return args[0]
    if origin in (list, tuple, set, frozenset):
        return []
    if origin is dict or annotation is dict:
        return {}
    if inspect.isclass(annotation) and issubclass(annotation, BaseModel):
        return _minimal_payload(annotation)
    return {str: "x", int: 0, float: 0.0, bool: False}.get(annotation, "x")


def _minimal_payload(model: type[BaseModel]) -> dict[str, Any]:
    payload = {name: _minimal_value(field.annotation) for name, field in model.model_fields.items()
               if field.is_required()}
    payload.update(OVERRIDES.get(model.__name__, {}))
    # Lift numbers to the bounds the model declares (`Field(ge=1)`), wherever they are nested.
    for _ in range(10):
        try:
            model.model_validate(payload)
            return payload
        except ValidationError as exc:
            bounded = [e for e in exc.errors() if "ge" in e.get("ctx", {}) or "gt" in e.get("ctx", {})]
            if not bounded:
                return payload
            for error in bounded:
                target: Any = payload
                *path, last = error["loc"]
                for part in path:
                    target = target[part]
                ctx = error["ctx"]
                target[last] = ctx["ge"] if "ge" in ctx else ctx["gt"] + 1
    return payload


def _valid_json(model: type[Record]) -> dict[str, Any]:
    payload = _minimal_payload(model)
    model.model_validate(payload)   # the generic minimal payload must itself be valid
    return payload


def _wrong_value(annotation: Any) -> Any:
    """A JSON value no field of this annotation accepts (objects for scalars, lists for dicts)."""
    origin = typing.get_origin(annotation)
    if origin is dict or annotation is dict:
        return [1, 2]
    if annotation is typing.Any:
        return pytest.skip("an Any field accepts every value")
    return {"not": ["this"]}


ids = [m.__name__ for m in RECORDS]


def test_every_record_is_covered() -> None:
    names = {m.__name__ for m in RECORDS}
    assert {"SampleBatch", "RunFinished", "RunMetadata", "DaqStatus", "FitReport", "BusConfig"} <= names


@pytest.mark.parametrize("model", RECORDS, ids=ids)
def test_a_minimal_valid_payload_round_trips(model: type[Record]) -> None:
    payload = json.dumps(_valid_json(model)).encode()
    record = model.from_json_bytes(payload)
    assert model.from_json_bytes(record.to_json_bytes()) == record


MALFORMED = [b"", b"{", b"}", b"null", b"[]", b"42", b'"text"', b"\xff\xfe\x00", b'{"a":', b"{'a': 1}",
             b"\x00" * 64, b'{"schema_version": 1,}', "é".encode("latin-1")]


@pytest.mark.parametrize("model", RECORDS, ids=ids)
@pytest.mark.parametrize("payload", MALFORMED, ids=[repr(p)[:20] for p in MALFORMED])
def test_malformed_json_is_a_schema_error(model: type[Record], payload: bytes) -> None:
    with pytest.raises(SchemaError) as info:
        model.from_json_bytes(payload)
    assert info.value.what == model.__name__
    assert f"expected a valid {model.__name__}" in str(info.value)


@pytest.mark.parametrize("model", RECORDS, ids=ids)
def test_every_field_with_a_wrong_type_is_a_schema_error_naming_the_field(model: type[Record]) -> None:
    valid = _valid_json(model)
    for name, field in model.model_fields.items():
        if field.annotation is typing.Any:
            continue
        payload = {**valid, name: _wrong_value(field.annotation)}
        with pytest.raises(SchemaError) as info:
            model.from_json_bytes(json.dumps(payload))
        assert name in str(info.value), (name, str(info.value))


@pytest.mark.parametrize("model", RECORDS, ids=ids)
def test_a_missing_required_field_is_a_schema_error(model: type[Record]) -> None:
    valid = _valid_json(model)
    for name in [n for n, f in model.model_fields.items() if f.is_required()]:
        payload = {k: v for k, v in valid.items() if k != name}
        with pytest.raises(SchemaError, match=name):
            model.from_json_bytes(json.dumps(payload))


@pytest.mark.parametrize("model", RECORDS, ids=ids)
def test_an_extra_field_is_a_schema_error(model: type[Record]) -> None:
    payload = {**_valid_json(model), "run_as_root": True}
    with pytest.raises(SchemaError, match="run_as_root"):
        model.from_json_bytes(json.dumps(payload))


@pytest.mark.parametrize("model", RECORDS, ids=ids)
def test_another_schema_version_is_a_schema_error(model: type[Record]) -> None:
    payload = {**_valid_json(model), "schema_version": model.SCHEMA_VERSION + 1}
    with pytest.raises(SchemaError, match="schema_version"):
        model.from_json_bytes(json.dumps(payload))


@pytest.mark.parametrize("model", RECORDS, ids=ids)
def test_an_oversized_payload_is_refused_before_parsing(model: type[Record]) -> None:
    # Valid JSON, padded with whitespace: only the size is wrong.
    valid = json.dumps(_valid_json(model)).encode()
    payload = valid + b" " * (MAX_PAYLOAD_BYTES + 1 - len(valid))
    with pytest.raises(SchemaError, match=f"at most {MAX_PAYLOAD_BYTES} bytes"):
        model.from_json_bytes(payload)
    assert model.from_json_bytes(payload[:MAX_PAYLOAD_BYTES]) == model.from_json_bytes(valid)


def test_a_deeply_nested_payload_is_a_schema_error_not_a_recursion_error() -> None:
    from schemas.fit import FitReport

    deep = b'{"bench":"b","run_id":"r","worker":"w","status":"ok","extra":{"a":' + b"[" * 100_000 \
        + b"]" * 100_000 + b"}}"
    with pytest.raises(SchemaError):
        FitReport.from_json_bytes(deep)


# --- property tests -------------------------------------------------------------------------------

json_values = st.recursive(
    st.none() | st.booleans() | st.integers(-2**70, 2**70) | st.floats(allow_nan=False) | st.text(max_size=20),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=12), inner, max_size=4),
    max_leaves=20)


def _parse_or_schema_error(model: type[Record], payload: bytes) -> None:
    try:
        record = model.from_json_bytes(payload)
    except SchemaError as exc:
        assert exc.what == model.__name__ and str(exc).startswith(f"{model.__name__}: expected ")
        return
    # Whatever was accepted must survive its own round trip (what a receiver would see).
    assert model.from_json_bytes(record.to_json_bytes()) == record


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(model=st.sampled_from(RECORDS), data=st.binary(max_size=300))
def test_random_bytes_never_raise_anything_but_schema_error(model: type[Record], data: bytes) -> None:
    _parse_or_schema_error(model, data)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(model=st.sampled_from(RECORDS), value=json_values)
def test_random_json_never_raises_anything_but_schema_error(model: type[Record], value: Any) -> None:
    _parse_or_schema_error(model, json.dumps(value).encode())


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(model=st.sampled_from(RECORDS), data=st.data())
def test_mutated_valid_payloads_never_raise_anything_but_schema_error(model: type[Record],
                                                                      data: st.DataObject) -> None:
    payload = _valid_json(model)
    names = sorted(model.model_fields)
    for _ in range(data.draw(st.integers(1, 3))):
        name = data.draw(st.sampled_from(names))
        if data.draw(st.booleans()):
            payload[name] = data.draw(json_values)
        else:
            payload.pop(name, None)
    _parse_or_schema_error(model, json.dumps(payload).encode())


def test_non_finite_numbers_are_refused_or_survive_the_round_trip() -> None:
    """JSON `NaN`/`Infinity` (Python's json writes them): a record accepting one must still
    parse after its own `to_json_bytes` (pydantic writes them as `null`)."""
    broken = []
    for model in RECORDS:
        for name in [n for n, f in model.model_fields.items() if f.annotation is float]:
            for bad in ("NaN", "Infinity"):
                text = json.dumps({**_valid_json(model), name: 0.5}).replace("0.5", bad, 1)
                try:
                    _parse_or_schema_error(model, text.encode())
                except SchemaError:
                    broken.append(f"{model.__name__}.{name}={bad}")
    assert broken == []


def test_names_that_become_keys_or_paths_are_checked_in_the_records() -> None:
    """`bench`, `run_id` and `worker` end up in Zenoh keys and in file paths
    (`<runs>/<bench>/<run_id>.fit/`): a record carrying `..` or `/` must not validate."""
    from schemas.daq import RunFinished
    from schemas.fit import FitReport

    base = {"bench": "b1", "run_id": "r1", "status": "complete", "file": "r1.mcap", "n_samples": 1,
            "release_time_s": 0.1, "duration_s": 1.0}
    for field, bad in (("bench", ".."), ("bench", "../../tmp"), ("run_id", "/etc/passwd"),
                       ("run_id", "a/b"), ("run_id", "x\x00y"), ("file", "../../etc/passwd"),
                       ("file", "/etc/passwd")):
        with pytest.raises((SchemaError, ValidationError)):
            RunFinished.from_json_bytes(json.dumps({**base, field: bad}))
    with pytest.raises((SchemaError, ValidationError)):
        FitReport.from_json_bytes(json.dumps({"bench": "..", "run_id": "r", "worker": "w", "status": "fitting"}))
