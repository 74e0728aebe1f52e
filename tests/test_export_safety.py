"""Text from outside (a fit file's fields, a file name, a family's formula) cannot hijack the
generated code: every line terminator of every language, comment terminators and line
splices stay inside the header comment. Checked by compiling what is generated: a payload
that escaped its comment would be an `#error` (C, CUDA, GLSL, HLSL) or a syntax error (WGSL).
"""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path
from typing import ClassVar

import pytest

import attenfit
from attenfit import export as ex
from attenfit._shaders._text import comment_safe

#: Line terminators of each language (C, HLSL and CUDA follow C; GLSL too).
C_LIKE = ["\n", "\r", "\r\n"]
WGSL = ["\n", "\r", "\r\n", "\x0b", "\x0c", "\x85", "\u2028", "\u2029"]
#: Ways to end a line comment without a terminator character of its own.
SPLICES = ["\\", "??/", "*/", "/*"]


def _payloads(terminators: list[str], escape: str) -> list[str]:
    out = [f"disk{t}{escape}{t}//" for t in terminators]
    out += [f"disk{s}" for s in SPLICES]
    return out


def _fit(tmp_path: Path, **fields) -> Path:
    fit = {"family": "disk_facing", "params": {"r": 0.2}, "metrics": {"max_rel_error": 0.01}}
    fit.update(fields)
    path = tmp_path / "fits.json"
    path.write_text(json.dumps(fit))
    return path


def test_comment_safe_leaves_printable_ascii_alone_and_escapes_the_rest():
    assert comment_safe("2/(s (s + d)), r = 0.1") == "2/(s (s + d)), r = 0.1"
    assert comment_safe("a\nb\r\u2028\x85") == "a\\x0ab\\x0d\\u2028\\x85"
    assert comment_safe("a\\") == "a\\x5c" and comment_safe("a??/") == "a?\\x3f/"
    assert comment_safe("*/ /*") == "* / / *"


def _compile(lang: str, src: str, tmp_path: Path) -> subprocess.CompletedProcess:
    if lang == "c":
        tool = shutil.which("cc") or pytest.skip("no C compiler")
        (tmp_path / "x.c").write_text("#include <math.h>\n" + src)
        cmd = [tool, "-std=c99", "-trigraphs", "-Wall", "-Werror", "-Wno-comment", "-c",
               "x.c", "-o", "x.o"]  # fmt: skip
    elif lang == "glsl":
        tool = shutil.which("glslangValidator") or pytest.skip("glslangValidator not installed")
        (tmp_path / "x.frag").write_text(
            "#version 450\nlayout(location = 0) out vec4 o;\n"
            + src
            + "void main() { o = vec4(attenfit_disk_facing(1.0)); }\n"
        )
        cmd = [tool, "x.frag"]
    else:
        tool = shutil.which("naga") or pytest.skip("naga not installed")
        (tmp_path / "x.wgsl").write_text(src, encoding="utf-8", newline="")
        cmd = [tool, "x.wgsl"]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=tmp_path)


ESCAPES = {"c": "#error injected", "glsl": "#error injected", "wgsl": "fn injected( {"}


@pytest.mark.parametrize("lang", ["c", "glsl", "wgsl"])
def test_the_checks_are_not_vacuous(lang, tmp_path):
    """An unsanitised payload does break the compile: the tests below would see an escape."""
    term = "\u2028" if lang == "wgsl" else "\r"
    src = ex.export("disk_facing", lang)
    bad = f"// fitted to disk{term}{ESCAPES[lang]}{term}//\n" + src
    assert _compile(lang, bad, tmp_path).returncode != 0


@pytest.mark.parametrize("lang", ["c", "glsl", "wgsl"])
@pytest.mark.parametrize("field", ["configuration", "metric key", "converged", "folder"])
def test_hostile_fit_fields_stay_in_the_comment(lang, field, tmp_path):
    terms = WGSL if lang == "wgsl" else C_LIKE
    for k, payload in enumerate(_payloads(terms, ESCAPES[lang])):
        where = tmp_path / f"{k}"
        where.mkdir()
        if field == "configuration":
            path = _fit(where, configuration=payload)
        elif field == "metric key":
            path = _fit(where, metrics={f"err{payload}": 0.5})
        elif field == "converged":
            path = _fit(where, converged=payload)
        else:
            folder = where / f"x{payload.replace('/', '|')}"
            folder.mkdir()
            path = _fit(folder)
        src = ex.export(path, lang)
        assert all(ch == "\n" or 0x20 <= ord(ch) < 0x7F for ch in src), repr(payload)
        proc = _compile(lang, src, where)
        assert proc.returncode == 0, (repr(payload), proc.stdout, proc.stderr)


def test_the_define_of_the_security_review_is_inert(tmp_path):
    """The reported attack: a `#define` in `configuration` rewrote sqrtf in the C export."""
    path = _fit(tmp_path, configuration="disk\n#define sqrtf(x) (x)\n//")
    src = ex.export(path, "c", form="stable")
    assert "\n#define" not in src
    assert "fitted to disk\\x0a#define sqrtf(x) (x)\\x0a//" in src


def test_a_user_familys_text_is_sanitised_too():
    Evil = attenfit.family_from_function(
        lambda d, r: 1 / (d * d + r * r),
        name="evil_text_test",
        defaults={"r": 0.1},
        formula="1/(d^2 + r^2)\n#error formula",
        source="*/ source\u2028",
        register=False,
    )
    src = ex.export(Evil(), "glsl")
    assert "\n#error" not in src and "\u2028" not in src and "*/" not in src


@pytest.mark.parametrize("lang", ["c", "wgsl"])
def test_hostile_fit_of_an_area_model_stays_in_the_comment(lang, tmp_path):
    """An area model's header quotes a fit's metrics too: the same escapes apply."""
    terms = WGSL if lang == "wgsl" else C_LIKE
    for k, payload in enumerate(_payloads(terms, ESCAPES[lang])):

        class Result:  # duck-typed FitResult of an area model
            model = attenfit.area.UnrealWrap(k=1.2)
            metrics: ClassVar = {f"err{payload}": 0.5}
            converged = payload

        src = ex.export(Result(), lang)
        assert all(ch == "\n" or 0x20 <= ord(ch) < 0x7F for ch in src), repr(payload)
        where = tmp_path / f"{k}"
        where.mkdir()
        proc = _compile(lang, src, where)
        assert proc.returncode == 0, (repr(payload), proc.stdout, proc.stderr)
