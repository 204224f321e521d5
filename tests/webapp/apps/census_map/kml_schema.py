"""Validation against the OGC KML 2.2 schema and Google's ``gx`` extension schema.

Both ship with pykml (with the atom and xAL schemas they import). Every schema is
loaded from there, whatever location a schema names: tests never use the network.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path
from typing import Any

import pykml
from lxml import etree

SCHEMAS = Path(pykml.__file__).parent / "schemas"
SCHEMA_FILES = ("ogckml22.xsd", "kml22gx.xsd", "atom-author-link.xsd", "xAL.xsd")
KML_NS = "http://www.opengis.net/kml/2.2"
GX_NS = "http://www.google.com/kml/ext/2.2"

# Imports both namespaces by their published addresses; the resolver maps them home.
WRAPPER = f"""<schema xmlns="http://www.w3.org/2001/XMLSchema">
  <import namespace="{KML_NS}" schemaLocation="http://schemas.opengis.net/kml/2.2.0/ogckml22.xsd"/>
  <import namespace="{GX_NS}" schemaLocation="http://code.google.com/apis/kml/schema/kml22gx.xsd"/>
</schema>"""


class LocalSchemas(etree.Resolver):
    """Serves the four schema files from pykml and refuses anything else."""

    def resolve(self, url: str, pubid: str | None, context: Any) -> Any:
        name = url.rsplit("/", 1)[-1]
        if name not in SCHEMA_FILES:
            raise LookupError(f"schema {url} is not shipped with pykml")
        return self.resolve_filename(str(SCHEMAS / name), context)


@cache
def kml_schema() -> etree.XMLSchema:
    parser = etree.XMLParser(no_network=True)
    parser.resolvers.add(LocalSchemas())
    wrapper = etree.fromstring(WRAPPER, parser, base_url=str(SCHEMAS / "wrapper.xsd"))
    return etree.XMLSchema(wrapper)


def assert_valid_kml(text: str | bytes) -> None:
    """Raise AssertionError, with lxml's error log, unless ``text`` is valid KML 2.2."""
    data = text.encode() if isinstance(text, str) else text
    document = etree.fromstring(data, etree.XMLParser(no_network=True, resolve_entities=False))
    schema = kml_schema()
    if not schema.validate(document):
        raise AssertionError(f"invalid KML:\n{schema.error_log}")
