"""``harness schema run.config|target|adapter|record [--markdown]``: print the JSON Schema of one kind of the
harness' files (``harness.config``), for an editor to validate a file while it is typed (VS Code:
``"json.schemas": [{"fileMatch": ["run.config"], "url": "./run.config.schema.json"}]``). ``--markdown``
prints the run.config reference instead (docs/run-config.md is that output)."""
import json

from harness.adapters.base import UserError
from harness.config.export import KINDS, json_schema, markdown

NAME = "schema"
HELP = "print the JSON Schema of run.config, target, adapter or record files"


def configure(parser):
    parser.add_argument("kind", choices=sorted(KINDS), help="which file kind")
    parser.add_argument("--markdown", action="store_true",
                        help="the reference as Markdown instead (run.config only: docs/run-config.md)")


def run(args) -> int:
    if args.markdown:
        if args.kind != "run.config":
            raise UserError(f"--markdown: only for run.config (docs/run-config.md), not {args.kind}")
        print(markdown(), end="")
        return 0
    print(json.dumps(json_schema(args.kind), indent=1))
    return 0
