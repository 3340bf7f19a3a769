from django.db import migrations, models


def fill_breakdown(apps, schema_editor):
    """Runs recorded before: their breakdown is the section times already in their timing (averages only)."""
    from harness.analysis.breakdown import from_timing

    Run = apps.get_model("harness", "Run")
    for run in Run.objects.exclude(timing={}).only("id", "timing").iterator():
        breakdown = from_timing(run.timing)
        if breakdown:
            Run.objects.filter(pk=run.pk).update(breakdown=breakdown)


class Migration(migrations.Migration):

    dependencies = [
        ('harness', '0004_stepping_time'),
    ]

    operations = [
        migrations.AddField(
            model_name='run',
            name='breakdown',
            field=models.JSONField(blank=True, default=dict, help_text="the timing breakdown in the harness' sections, s with min/avg/max over ranks where the code prints them, ranks and load imbalance (harness.analysis.breakdown)"),
        ),
        migrations.AddField(
            model_name='run',
            name='profile',
            field=models.CharField(blank=True, default='', help_text="the run's sampling profile as folded stacks, a file in its run folder (harness.execution.profiles); blank: not profiled", max_length=200),
        ),
        migrations.RunPython(fill_breakdown, migrations.RunPython.noop),
    ]
