"""The lab report as a Jupyter notebook (`report.ipynb`), from the same blocks as report.md.

Markdown cells carry the derivation and the text (equations as `$$…$$`, rendered by the
notebook's MathJax), code cells carry every step (`Code` blocks, `ident.report.code`); run
top to bottom in a fresh kernel beside `data/`, they recompute every number of the report.
`execute` runs it headless (nbclient and ipykernel) so the written notebook holds its outputs.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ident.report.document import Block, Code, to_markdown

if TYPE_CHECKING:
    from nbformat.notebooknode import NotebookNode

KERNEL = {"name": "python3", "display_name": "Python 3", "language": "python"}


def to_notebook(blocks: list[Block]) -> NotebookNode:
    """Consecutive non-code blocks become one Markdown cell; each `Code` one code cell."""
    import nbformat  # deferred: keeps `import ident` fast
    cells: list[NotebookNode] = []
    text: list[Block] = []
    for block in blocks:
        if isinstance(block, Code):
            if text:
                cells.append(nbformat.v4.new_markdown_cell(to_markdown(text).strip()))
                text = []
            cells.append(nbformat.v4.new_code_cell(block.source))
        else:
            text.append(block)
    if text:
        cells.append(nbformat.v4.new_markdown_cell(to_markdown(text).strip()))
    notebook = nbformat.v4.new_notebook(cells=cells)
    notebook.metadata["kernelspec"] = KERNEL
    notebook.metadata["language_info"] = {"name": "python"}
    return notebook


def execute(notebook: NotebookNode, directory: Path, timeout_s: float = 600.0) -> NotebookNode:
    """Run every cell in a fresh kernel with `directory` as its working directory.

    Raises `nbclient.exceptions.CellExecutionError` naming the cell when one fails.
    """
    from nbclient import NotebookClient

    # the kernel listens on loopback only; its start-up warning about that is noise here
    client = NotebookClient(notebook, timeout=int(timeout_s), kernel_name=KERNEL["name"],
                            resources={"metadata": {"path": str(directory)}},
                            extra_arguments=["--IPKernelApp.log_level=ERROR"])
    client.execute()
    return notebook


def write(notebook: NotebookNode, path: Path) -> None:
    import nbformat  # deferred: keeps `import ident` fast
    nbformat.validate(notebook)
    path.write_text(nbformat.writes(notebook))


__all__ = ["KERNEL", "execute", "to_notebook", "write"]
