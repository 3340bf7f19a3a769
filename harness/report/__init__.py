"""How results are shown: the JUnit XML writer (CLI and dashboard), plain-text tables, the glossary of
states and reasons, and links to the dashboard.

Owns: junit, textout, glossary, links.
May import: ``harness.store`` (rules and the runs it writes about) and the standard library; nothing of the
layers that compute results.
"""
