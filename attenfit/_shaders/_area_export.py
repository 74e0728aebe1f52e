"""An area model as a self-contained GLSL, HLSL, WGSL, C or CUDA function of the receiver
geometry, with the header a family's export has.

The function is `float NAME(float d, float cos_r, float cos_e, float r, float cos_n, float g)`:
the six `AreaInputs` in their order (`attenfit._curves._area`), the light's radius `r` one of
them (an engine reads it from the light's data), so that one function serves every light of
the model and reads what `model(d, cos_r, cos_e, r, cos_n, g)` reads. It returns `E / I` in
1/length^2. The body is the model's shader form (`AreaModel.shader_form`: the engine's code
its model cites, with the engine's clamps) with the radius made an input (`area_export_form`),
printed by `_print`; an area model has no stable form (its JAX code is not traced). The model's parameters are baked in as float32 literals or read from
uniforms (C and CUDA: extra arguments after `g`), as a family's. Every text in the header goes
through `_text.comment_lines`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from .._curves import AreaModel, Model
from .._errors import BadValueError
from .._ir import Call, Expr, Ref, ShaderForm
from .._version import __version__
from ._print import print_form
from ._text import finish_header, float32_literal, scalar_params

__all__ = ["area_export_form", "area_source"]


def area_source(
    model: AreaModel,
    lang: str,
    fname: str,
    *,
    uniforms: bool = False,
    info: Mapping[str, Any] | None = None,
    header: bool = True,
    notes: Sequence[str] = (),
) -> str:
    """The function `fname(d, cos_r, cos_e, r, cos_n, g)` of `model` in `lang` (see the module
    docstring), after its header comment (unless `header=False`); `info` is a fit's (as for a
    family), `notes` more header lines (what a scene says of it)."""
    made = area_export_form(model)
    if made is None:
        inner = _inner(model)
        what = f" (family {inner.name!r} has none)" if inner is not None else ""
        raise BadValueError(f"area model {model.name!r} has no shader form{what}: cannot export it")
    form, renamed = made
    values = scalar_params(model)
    lines = []
    if header:
        lines = _header(model, form, renamed, values, info or {}, lang, fname, uniforms, notes)
    printed = {renamed.get(p, p): v for p, v in values.items()}
    return print_form(form, lang, fname, printed, uniforms=uniforms, header=lines)


def area_export_form(model: AreaModel) -> tuple[ShaderForm, dict[str, str]] | None:
    """The form `export` prints: `model`'s shader form with the light's size an input (its
    `form_sizes`: the radius `r`; a rectangle's `hw`, `hh`), the inputs in `input_names`
    order (`d, cos_r, cos_e, r, cos_n, g`, as `AreaModel.__call__` takes them), and the names it renamed (a parameter or temporary named like an input,
    e.g. the family `r` of `PointLight(Yuksel())`, gets a `_param`/`_let` suffix), or None
    when the model has no shader form."""
    form = model.shader_form()
    if form is None:
        return None
    names = type(model).input_names
    swap: dict[tuple[str, str], Ref] = {}
    for size, arg in type(model).form_sizes.items():  # the light's size: an input
        if size in form.params and size not in model.param_names():
            swap[(size, "param")] = Ref(arg, "d")
    taken = set(names) | set(form.params) | {n for n, _ in form.lets}
    renamed: dict[str, str] = {}
    for name, kind in [*((p, "param") for p in form.params), *((n, "let") for n, _ in form.lets)]:
        if name in names and (name, kind) not in swap:
            new = f"{name}_{kind}"
            while new in taken:
                new += "_"
            taken.add(new)
            renamed[name] = new
            swap[(name, kind)] = Ref(new, kind)

    def sub(e: Expr) -> Expr:
        if isinstance(e, Ref):
            return swap.get((e.name, e.kind), e)
        if isinstance(e, Call):
            return Call(e.op, tuple(sub(a) for a in e.args))
        return e

    kept = [p for p in form.params if swap.get((p, "param")) is None or p in renamed]
    params = tuple(renamed.get(p, p) for p in kept)
    lets = tuple((renamed.get(n, n), sub(e)) for n, e in form.lets)
    out = ShaderForm(form.family, params, lets, sub(form.result), form.source, form.engine,
                     form.note, names)  # fmt: skip
    return out, renamed


def _inner(model: Model) -> Model | None:
    """The model whose parameters `model` reads (`PointLight`'s family: `params_field`)."""
    field = type(model).params_field
    return None if field is None else getattr(model, field)


def _header(
    model: AreaModel,
    form: Any,
    renamed: Mapping[str, str],
    values: Mapping[str, float],
    info: Mapping[str, Any],
    lang: str,
    fname: str,
    uniforms: bool,
    notes: Sequence[str],
) -> list[str]:
    clike = lang in ("c", "cuda")
    where = "arguments after g" if uniforms and clike else ("uniforms" if uniforms else "baked in")
    shown = ", ".join(
        f"{p} = {float32_literal(v)}" + (f" (written {renamed[p]})" if p in renamed else "")
        for p, v in values.items()
    )
    inner = _inner(model)
    lines = [
        f"{fname}({', '.join(type(model).input_names)}): E / I, the irradiance of an area light over its "
        "intensity, at a receiver.",
        f"model   : {model.name} (an area model; lights: {model.light})",
        f"formula : {model.formula}",
    ]
    if inner is not None:
        lines.append(f"          f = {inner.name}: {inner.formula} (source: {inner.source})")
    lines += [
        f"source  : {model.source}",
        f"form    : shader, {'as in' if form.engine else 'after'} {form.source}",
    ]
    if form.note:
        lines.append(f"          differs from the JAX model: {form.note}")
    lines.append(f"params  : {shown} ({where})" if shown else "params  : none")
    width = max(map(len, type(model).input_names))
    for k, x in enumerate(type(model).input_names):
        lines.append(
            f"{'inputs  :' if k == 0 else ' ' * 9} {x:<{width}}  {type(model).input_text[x]}"
        )
    lines.append(f"output  : {type(model).output_text}")
    generated = (
        f"Generated by attenfit {__version__} from the model's shader form (an area model has "
        "no stable form).",
    )
    return finish_header(lines, info, notes, generated, lang)
