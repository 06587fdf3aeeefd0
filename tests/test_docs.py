"""The README (the student's quick start) and `docs/` (the manual) stay in step with the code
and the repository: option tables match the code, every file they name exists."""

import re
from pathlib import Path

from daq.serial_handlers.protocol_replay import describe_replay_options
from daq.sim import describe_options

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
PAGES = sorted((ROOT / "docs").glob("*.md"))

#: A path in backquotes that names a file or folder of this repository.
_REPO_PATH = re.compile(r"`((?:daq|ident|schemas|tools|tests|docs|testkit)/[A-Za-z0-9_./-]*"
                        r"(?:\.[a-z0-9]+|/))`")
_LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")


def _option_names(table: str) -> list[str]:
    return re.findall(r"^\| `([a-z_0-9]+)` \|", table, flags=re.M)


def test_every_sim_and_replay_option_is_in_the_daq_page_with_its_current_row() -> None:
    daq_page = (ROOT / "docs" / "daq.md").read_text()
    rows = [row for table in (describe_options(), describe_replay_options())
            for row in table.splitlines() if row.startswith("| `")]
    assert len(_option_names(describe_options())) >= 30
    missing = [row for row in rows if row not in daq_page]
    assert missing == []


def test_the_two_set_up_commands_are_the_first_commands() -> None:
    first_block = README.split("```sh", 1)[1].split("```", 1)[0]
    assert [line.split()[1] for line in first_block.strip().splitlines()] == ["demo", "test"]
    assert README.count("make ") == README.count("make demo") + README.count("make test")


def test_the_quick_start_comes_first_and_names_the_students_steps() -> None:
    headings = re.findall(r"^## (.+)$", README, flags=re.M)
    assert headings[0] == "Quick start" and "Troubleshooting" in headings
    quick = README.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    for step in ("daq run", "daq serve", "ident report", "hand in"):
        assert step in quick, step


def test_links_and_file_names_point_into_the_repository() -> None:
    problems = []
    for page in [ROOT / "README.md", *PAGES]:
        text = page.read_text()
        for target in _LINK.findall(text):
            if not target.startswith(("http://", "https://")) and \
                    not (page.parent / target).exists():
                problems.append(f"{page.name}: link {target}")
        for name in _REPO_PATH.findall(text):
            if not (ROOT / name).exists():
                problems.append(f"{page.name}: {name}")
    assert problems == []


def test_every_docs_page_is_linked_from_the_readme() -> None:
    assert PAGES, "docs/ is empty"
    assert [p.name for p in PAGES if f"(docs/{p.name})" not in README] == []


def test_every_markdown_file_named_is_in_the_repository() -> None:
    present = {p.name for p in ROOT.rglob("*.md") if ".venv" not in p.parts}
    named = {name for page in [ROOT / "README.md", *PAGES]
             for name in re.findall(r"\b[A-Za-z_.-]+\.md\b", page.read_text())}
    assert sorted(named - present) == []
