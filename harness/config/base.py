"""The common base of the file models: strict JSON types, unknown fields refused, field names as written."""
from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class FileModel(BaseModel):
    """A JSON object of one of the harness' files. Strict: ``"2"`` is no integer and ``true`` no number, as
    the readers check; a field not declared is an error (``additionalProperties: false`` in the schema)."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True, use_attribute_docstrings=True)


class OpenModel(FileModel):
    """An object whose readers ignore fields they do not know (a run record of a newer harness)."""

    model_config = ConfigDict(extra="allow")


def known_fields(model: type[BaseModel]) -> set[str]:
    """The field names of ``model`` as they are written in the file (aliases included)."""
    return {info.alias or name for name, info in model.model_fields.items()}
