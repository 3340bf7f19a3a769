"""docs/glossary.md says what harness/report/glossary.py says (the dashboard's tooltips and the CLI's help use the
module): every word with its very sentence, and no word the module lacks."""
import re

from harness.execution.workspace import PROJECT_ROOT
from harness.report import glossary


def test_the_glossary_page_holds_every_word_of_the_module():
    text = (PROJECT_ROOT / "docs" / "glossary.md").read_text()
    sections = dict(re.findall(r"^## (.+)\n((?:.*\n)*?)(?=^## |\Z)", text + "\n", re.M))
    assert set(sections) == set(glossary.SECTIONS)
    for title, words in glossary.SECTIONS.items():
        rows = dict(re.findall(r"^\| ([^|]+?) \| ([^|]+) \|$", sections[title], re.M))
        rows.pop("word", None)
        rows.pop("---", None)
        assert rows == words, title


def test_every_dashboard_tooltip_names_a_glossary_word():
    """A ``{% glossary 'word' %}`` in a template names a word the glossary defines (else the page fails)."""
    used = set()
    for template in (PROJECT_ROOT / "webfrontend" / "templates").rglob("*.html"):
        used |= set(re.findall(r"{% glossary '([^']+)' %}", template.read_text()))
    assert used and used <= set(glossary.ALL)


def test_every_stored_consistency_level_has_the_glossary_word_the_cli_junit_and_pages_print(store):
    """``level_word`` (check's table, list, JUnit, the pages) gives the glossary's level for each stored run level,
    the model's label says the same (Django capitalises it; no page prints it), and a quantity's length mismatch or missing quantity reads as
    the glossary's "inconsistent" sentence names it."""
    from harness.analysis.consistency import LENGTH_MISMATCH, MISSING
    from harness.store.models import Run

    for value, label in Run.Consistency.choices:
        assert glossary.level_word(value) == label.lower() and label.lower() in glossary.LEVELS
    assert "different lengths" in glossary.LEVELS["inconsistent"] and glossary.level_word(LENGTH_MISMATCH) == "length mismatch"
    assert "missing" in glossary.LEVELS["inconsistent"] and glossary.level_word(MISSING) == "missing"
