"""Code shown with its real output: ``.. s2gen-run::`` runs its Python content during the build.

The blocks of one page share a namespace and run in order, in a scratch folder of their own,
so a page reads as one continuous script. The directive shows the code, then what it printed
(standard output, and the one-line message of an exception when ``:raises:`` names its class).
Any other exception fails the build, so a page can never show output its code no longer gives.

Options: ``:raises: SpecError`` (the block must raise that exception; its message is shown),
``:hide-code:`` (only the output), ``:image: NAME.png`` (a figure the code wrote in the scratch
folder, shown after the output), ``:language: toml`` with ``:file: NAME`` (the content is
written to NAME in the scratch folder and shown as a file, nothing runs).
"""

from __future__ import annotations

import contextlib
import io
import os
import shutil
import tempfile
import textwrap
import traceback
from pathlib import Path
from typing import Any, ClassVar

from docutils import nodes
from docutils.parsers.rst import directives
from sphinx.util.docutils import SphinxDirective

_SCRATCH: dict[str, tempfile.TemporaryDirectory[str]] = {}
_NAMESPACES: dict[str, dict[str, Any]] = {}


def _scratch(docname: str) -> str:
    if docname not in _SCRATCH:
        _SCRATCH[docname] = tempfile.TemporaryDirectory(prefix="s2gen-docs-")
    return _SCRATCH[docname].name


def run_block(code: str, namespace: dict[str, Any], folder: str, raises: str = "") -> str:
    """Run `code` in `namespace` with `folder` as the working folder; what it printed (and,
    when `raises` names the exception it must raise, that exception's message).

    Example:
        >>> run_block("print(1 + 1)", {}, ".")
        '2\\n'
    """
    out = io.StringIO()
    before = os.getcwd()
    os.chdir(folder)
    try:
        with contextlib.redirect_stdout(out):
            exec(compile(code, "<s2gen-run>", "exec"), namespace)  # noqa: S102 (our own pages)
    except Exception as exc:
        if raises and type(exc).__name__ == raises:
            return out.getvalue() + f"{type(exc).__name__}: {exc}\n"
        raise RuntimeError(
            "a code block of the documentation failed:\n"
            + code
            + "\n"
            + "".join(traceback.format_exception(exc))
        ) from exc
    finally:
        os.chdir(before)
    if raises:
        raise RuntimeError(f"this block was to raise {raises} and did not:\n{code}")
    return out.getvalue()


class RunDirective(SphinxDirective):
    """Show Python code and run it, showing its output."""

    has_content = True
    option_spec: ClassVar[dict[str, Any]] = {
        "raises": directives.unchanged,
        "hide-code": directives.flag,
        "language": directives.unchanged,
        "file": directives.unchanged,
        "image": directives.unchanged,
    }

    def run(self) -> list[nodes.Node]:
        code = textwrap.dedent("\n".join(self.content)) + "\n"
        folder = _scratch(self.env.docname)
        language = self.options.get("language", "python")
        shown: list[nodes.Node] = []
        if "hide-code" not in self.options:
            if "file" in self.options:
                name = nodes.literal(text=self.options["file"])
                shown.append(nodes.paragraph("", "", nodes.Text("File "), name, nodes.Text(":")))
            shown.append(nodes.literal_block(code, code, language=language))
        if "file" in self.options:
            with open(os.path.join(folder, self.options["file"]), "w", encoding="utf-8") as f:
                f.write(code)
            return shown
        namespace = _NAMESPACES.setdefault(self.env.docname, {"__name__": "__docs__"})
        try:
            output = run_block(code, namespace, folder, self.options.get("raises", ""))
        except RuntimeError as exc:
            raise self.error(str(exc)) from None
        if output:
            shown.append(nodes.literal_block(output, output, language="text", classes=["output"]))
        if "image" in self.options:
            shown.append(self._image(folder, self.options["image"]))
        return shown

    def _image(self, folder: str, name: str) -> nodes.Node:
        """The figure `name` the block wrote, copied beside the sources (docs/_generated)."""
        target = (
            Path(self.env.srcdir) / "_generated" / f"{self.env.docname.replace('/', '-')}-{name}"
        )
        target.parent.mkdir(exist_ok=True)
        shutil.copyfile(Path(folder) / name, target)
        self.env.note_dependency(str(target))
        return nodes.image(uri="/" + target.relative_to(self.env.srcdir).as_posix(), width="80%")


def _forget(app: Any, env: Any, docnames: Any) -> None:
    """Pages read again start from a fresh namespace."""
    for name in docnames:
        _NAMESPACES.pop(name, None)


def setup(app: Any) -> dict[str, Any]:
    app.add_directive("s2gen-run", RunDirective)
    app.connect("env-before-read-docs", _forget)
    return {"parallel_read_safe": False, "parallel_write_safe": True}
