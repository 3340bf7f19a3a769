"""Template tags of the efficiency pages (webfrontend/efficiency.py) used inside other pages."""
from django import template

register = template.Library()


@register.inclusion_tag("webfrontend/parts/breakdown_table.html")
def breakdown_table(runs):
    """The timing breakdown of a run (or of compared runs, side by side): sections with min/avg/max over ranks,
    load imbalance, and links to the flame graphs."""
    from webfrontend.efficiency import breakdown_context

    return breakdown_context(runs if isinstance(runs, (list, tuple)) else [runs])
