"""The code blocks of the Markdown docs, read as a reader follows them (the docs tests' parser).

A page (README.md, docs/*.md) is a script: its ```python and ```bash blocks run in order,
Python blocks in one shared namespace, shell blocks with `bash -e -o pipefail`, all in one
temporary folder (with a copy of `examples/`, which the docs' commands read). An HTML
comment on the line before a block's fence changes how it runs:

* `<!-- docs: skip: REASON -->`: not run (e.g. `make test`, which is this test suite);
  the reason is required.
* `<!-- docs: small: --opt VALUE... --flag -->`: a block too slow for the test suite is
  run at a small size: on every `attenfit`/`python` command line of the block, each option
  given replaces that option's values, or is added where the line lacks it; the block as
  written is still parsed.
* `<!-- docs: exit N -->`: the shell block is expected to exit with status N (an example
  of an error).

`run_page.py`-style execution is in `tests/_doc_runner.py`; `tests/test_docs.py` drives it.
"""

from __future__ import annotations

import dataclasses
import re
import shlex
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
RUN = {"python": "python", "py": "python", "bash": "bash", "sh": "bash", "shell": "bash"}

_FENCE = re.compile(r"^(`{3,}|~{3,})\s*([\w+-]*)(.*)$")
_DIRECTIVE = re.compile(r"^<!--\s*docs:\s*(skip|small|exit)\s*:?\s*(.*?)\s*-->\s*$")


@dataclasses.dataclass(frozen=True)
class Block:
    """One fenced code block: its page, the line of its opening fence, language, code."""

    page: Path
    line: int
    lang: str
    code: str
    directive: str | None = None  # "skip" | "small" | "exit"
    argument: str = ""

    @property
    def where(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"

    @property
    def runs(self) -> bool:
        return self.lang in RUN and self.directive != "skip"


def blocks(page: Path) -> list[Block]:
    """Every fenced block of `page`, with the directive on the line before it, if any."""
    out: list[Block] = []
    lines = page.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        m = _FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        fence, lang = m.group(1), m.group(2).lower()
        start = i
        body: list[str] = []
        i += 1
        while i < len(lines) and not lines[i].startswith(fence):
            body.append(lines[i])
            i += 1
        if i == len(lines):
            raise ValueError(f"{page.name}:{start + 1}: code block never closed")
        directive, argument = None, ""
        if start > 0 and (d := _DIRECTIVE.match(lines[start - 1].strip())):
            directive, argument = d.group(1), d.group(2)
        out.append(Block(page, start + 1, lang, "\n".join(body) + "\n", directive, argument))
        i += 1
    return out


def _commands(code: str) -> list[str]:
    """The shell code as one command per line (continuation lines joined)."""
    return code.replace("\\\n", " ").splitlines()


def small(code: str, options: str, where: str) -> str:
    """`code` with the options of a `small` directive substituted (see the module docstring)."""
    opts: list[tuple[str, list[str]]] = []  # option -> its values (none: a flag)
    for word in shlex.split(options):
        if word.startswith("--"):
            opts.append((word, []))
        elif opts:
            opts[-1][1].append(word)
        else:
            raise ValueError(f"{where}: 'small' takes --options, got {word!r}")
    used: set[str] = set()
    out = []
    for line in _commands(code):
        if not line.strip() or line.lstrip().startswith("#"):
            out.append(line)
            continue
        argv = shlex.split(line, comments=True)
        if not argv or argv[0] not in ("attenfit", "python", "python3"):
            out.append(line)
            continue
        for name, values in opts:
            if name in argv:
                j = argv.index(name) + 1
                k = j
                while k < len(argv) and not argv[k].startswith("--"):
                    k += 1
                argv[j:k] = values
            else:
                argv += [name, *values]
            used.add(name)
        out.append(shlex.join(argv))
    if not used:
        raise ValueError(f"{where}: 'small' changes no command (none runs attenfit or python)")
    return "\n".join(out) + "\n"


def script(page: Path) -> list[dict]:
    """The blocks of `page` that run, as the runner takes them (small sizes substituted)."""
    out = []
    for b in blocks(page):
        if not b.runs:
            continue
        code = b.code
        if b.directive == "small":
            if RUN[b.lang] != "bash":
                raise ValueError(f"{b.where}: 'small' applies to shell blocks")
            code = small(code, b.argument, b.where)
        expect = int(b.argument) if b.directive == "exit" else 0
        out.append({"where": b.where, "lang": RUN[b.lang], "code": code, "exit": expect})
    return out
