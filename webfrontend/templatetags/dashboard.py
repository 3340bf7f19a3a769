"""Template helpers: the success bar of a folder (thesis 4.6.1) and small formatting filters."""
from django import template
from django.conf import settings

from harness.analysis.compare import SPEED_WORDS
from harness.config.record import STATE_LABELS
from harness.report.glossary import ALL, define, level_word
from webfrontend.presentation import provenance as facts
from webfrontend.presentation import speed_change as change

register = template.Library()

LABELS = {"successful": "successful", "failed": "failed", "not_executed": "not executed",
          "outdated": "outdated", "consistent": "consistent", "inconsistent": "inconsistent",
          "no_reference": "no reference run", "not_checked": "not checked"}


@register.inclusion_tag("webfrontend/parts/bar.html")
def tally_bar(tally, mode="state"):
    """Bar whose length is the share of successful (or consistent) runs, with the counts beside it."""
    categories = (("consistent", "inconsistent", "no_reference", "not_checked") if mode == "consistency"
                  else ("successful", "failed", "not_executed"))
    return {"tally": tally, "percent": round(100 * tally.share(mode), 1), "color": bar_color(tally, mode),
            "counts": [(LABELS[c], c, tally.counts.get(c, 0)) for c in categories],
            "outdated": tally.counts.get("outdated", 0), "mode": mode}


def bar_color(tally, mode="state") -> str:
    """What the bar's colour says: red when any run failed (or is inconsistent), grey when none did but some
    are not executed (or not checked), green when all succeeded. The thesis' rule (red below 25 % success,
    else blue) painted 3 failures of 4 a calm blue."""
    bad = tally.counts.get("inconsistent" if mode == "consistency" else "failed", 0)
    if bad:
        return "red"
    return "green" if tally.total and tally.share(mode) >= 1.0 else "grey"


def verdict(tally, mode="state") -> str:
    """One word for a target's current build: failing, incomplete, passing (or empty)."""
    return {"red": "failing", "grey": "incomplete" if tally.total else "empty", "green": "passing"}[
        bar_color(tally, mode)]


register.filter("verdict", verdict)


@register.filter
def seconds(value):
    """Run time for humans: 0.42 s, 12.3 s, 4 min 05 s, 2 h 03 min."""
    if value is None:
        return "-"
    value = float(value)
    if value < 60:
        return f"{value:.3g} s"
    if value < 3600:
        return f"{int(value // 60)} min {int(value % 60):02d} s"
    return f"{int(value // 3600)} h {int(value % 3600 // 60):02d} min"


@register.filter
def category_label(value):
    return LABELS.get(value, value)


@register.filter
def c_value(value):
    return "-" if value is None else f"{value:.4f}"


@register.filter
def num(value):
    """A float in its shortest exact-enough form (1000, 4.59e-05); '-' for none."""
    return "-" if value is None else f"{value:.6g}"


@register.inclusion_tag("webfrontend/parts/provenance.html")
def provenance(run, reference=True):
    """Short commit of the run's build, its test case content hash and the reference run's commit."""
    return {**facts(run), "show_reference": reference}


@register.simple_tag(takes_context=True)
def query_with(context, **changes):
    """The current query string with ``changes`` applied (a page link keeps mode, filter and machine)."""
    query = context["request"].GET.copy()
    for key, value in changes.items():
        query[key] = value
    return query.urlencode()


@register.simple_tag
def compare_limit():
    return settings.DASHBOARD_COMPARE_LIMIT


@register.filter
def speed_change(speed):
    """'+12 %' (slower) or '-8 %' (faster) of a stepping-time change (harness.store.queries.stepping_changes)."""
    return change(speed["ratio"], speed.get("noise") or 0.0)


@register.filter
def state_word(state):
    """A run state code in the glossary's words ("post_processed" -> "post-processed")."""
    return STATE_LABELS.get(state, state)


@register.filter
def speed_word(kind):
    """"slower", "faster" or "no speed change" (harness.store.rules.speed_kind), as ``harness compare`` says it."""
    return SPEED_WORDS.get(kind, kind)


VERDICT_LABELS = {"passed": "passed", "failed": "failed", "not_run": "not run", "skipped": "not run"}


@register.filter
def verdict_label(value):
    """The word of the glossary (docs/glossary.md) for a verdict category."""
    return VERDICT_LABELS.get(value, value)


@register.simple_tag
def glossary(term):
    """The glossary's sentence for ``term`` (harness.report.glossary, docs/glossary.md), for a tooltip."""
    return define(term)


@register.filter
def level_label(value):
    """A consistency level in the glossary's words (harness.report.glossary.level_word, as the CLI and JUnit)."""
    return level_word(value)


@register.filter
def defined(term):
    """The glossary's sentence for ``term``, or '' for a word it lacks (for tooltips on stored values)."""
    return ALL.get(str(term), "")
