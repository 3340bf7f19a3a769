"""The one form of the dashboard: overruling a failure or an inconsistency with a reason."""
from django import forms

from harness.store.rules import CONSISTENT_LEVELS, override_keys


class OverrideForm(forms.Form):
    """Quantity blank = the whole run; otherwise one quantity found not consistent by the check."""

    quantity = forms.ChoiceField(required=False, label="accept")
    reason = forms.CharField(widget=forms.Textarea(attrs={"rows": 3, "cols": 60}), max_length=5000,
                             strip=True, label="reason",
                             help_text="why this difference or failure is tolerable (kept and shown)")

    def __init__(self, run, *args, **kwargs):
        super().__init__(*args, **kwargs)
        bad = sorted({quantity_key(r) for r in run.consistency_results.all() if r.level not in CONSISTENT_LEVELS})
        self.fields["quantity"].choices = [("", "the whole run")] + [(q, f"quantity {q}") for q in bad]


def quantity_key(result) -> str:
    """The key an override stores for a quantity: one of those `harness check` honours
    (harness.store.rules.override_keys) - the bare name for thermo, "series:quantity" for other series."""
    bare, qualified = override_keys(result.series_name, result.quantity)[:2]
    return bare if result.series_kind == "thermo" else qualified
