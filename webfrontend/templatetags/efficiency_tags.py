"""Template tags of the efficiency pages (webfrontend/efficiency.py) used inside other pages."""
from django import template

from webfrontend.efficiency import breakdown_context

register = template.Library()


@register.inclusion_tag("webfrontend/parts/breakdown_table.html")
def breakdown_table(runs):
    """The timing breakdown of a run (or of compared runs, side by side): sections with min/avg/max over ranks,
    load imbalance, and links to the flame graphs."""
    return breakdown_context(runs if isinstance(runs, (list, tuple)) else [runs])


@register.filter
def share(value):
    """A fraction as a percentage with one decimal (0.123 -> '12.3 %', growth with its sign); '-' for none."""
    if value is None:
        return "-"
    return f"{100 * value:.1f} %"


@register.filter
def growth(value):
    return "-" if value is None else f"{100 * value:+.1f} %"
