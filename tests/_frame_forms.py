"""The rect and tube models' shader forms against their JAX forms (tests of both shapes)."""

import jax
import numpy as np

from attenfit._shaders import evaluate_area_form
from attenfit._truth import model_inputs


def form_and_model(model, emitter, points, normals) -> tuple[np.ndarray, np.ndarray]:
    """`model`'s shader form evaluated in float64 at the receivers, and the model itself."""
    with jax.enable_x64(True):
        x = model_inputs(model, emitter, points, normals)
        ref = np.asarray(model(*x))
    given = dict(zip(model.input_names, (np.asarray(v) for v in x), strict=True))
    return evaluate_area_form(model, given, np.float64), ref
