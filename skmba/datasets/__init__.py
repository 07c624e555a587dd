"""Reference problems of the thesis as dataset generators."""

__all__: list[str] = []
