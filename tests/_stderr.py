"""What a command says on stderr, with its progress set aside.

Progress stage lines (`attenfit scene: [  0.4 s] ground truth ...`) go to stderr wherever it
goes, a pipe or pytest's capture included (docs/performance.md, "Latency"); a refusal is the
one line besides them.
"""

import re

#: A progress stage line or count line.
STAGE_LINE = re.compile(r"attenfit [a-z]+: \[ *\d+\.\d s\] ")


def without_progress(text: str) -> str:
    """`text` without its progress lines."""
    return "\n".join(ln for ln in text.splitlines() if not STAGE_LINE.match(ln))
