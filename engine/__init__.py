"""The bundled DEM engine: a program (`python -m engine`, `dem`); see engine/README.md."""
