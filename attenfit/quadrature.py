"""Reference numerical integration of emitter irradiance (placeholder; filled in below)."""
