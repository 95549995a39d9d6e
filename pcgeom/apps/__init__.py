"""Applications built on the core: evaluation (and later boundary detection, reconstruction)."""

__all__: list[str] = []
