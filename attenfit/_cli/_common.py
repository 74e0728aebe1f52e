"""What every verb shares: the exit codes."""

#: Exit codes: success, an internal error (a bug), bad input, a fit that did not converge.
EXIT_OK, EXIT_ERROR, EXIT_BAD_INPUT, EXIT_NOT_CONVERGED = 0, 1, 2, 3
