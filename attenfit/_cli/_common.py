"""What every verb shares: the exit codes and the emitter `--emitter` names."""

#: Exit codes: success, an internal error (a bug), bad input, a fit that did not converge.
EXIT_OK, EXIT_ERROR, EXIT_BAD_INPUT, EXIT_NOT_CONVERGED = 0, 1, 2, 3


def configuration_emitter(kind: str, radius: float, intensity: float = 1.0, **options):
    """The emitter `--emitter KIND --radius R` names, the same for every verb: a sphere at the
    origin, a downlight disk facing -z, or a capsule along x (`half_length`, default 2 R).
    `options`: `two_sided` (disk), `half_length` (capsule)."""
    from .._truth import CapsuleEmitter, DiskEmitter, SphereEmitter

    origin = [0.0, 0.0, 0.0]
    if kind == "sphere":
        return SphereEmitter(origin, radius, intensity)
    if kind == "disk":
        return DiskEmitter(
            origin, [0.0, 0.0, -1.0], radius, intensity, options.get("two_sided", False)
        )
    half = options.get("half_length", 2 * radius)
    return CapsuleEmitter([-half, 0.0, 0.0], [half, 0.0, 0.0], radius, intensity)
