"""Files that run inside YADE's own Python (``/usr/bin/python3.11`` for Debian's ``/usr/bin/yade``), never
imported by the harness: ``launch.py`` starts a YADE script the way the harness runs it, ``yade_series.py``
is the helper a script imports to write its thermo series and timing (docs/yade.md). Standard library only:
YADE's interpreter has neither the harness nor pandas.
"""
