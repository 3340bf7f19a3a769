"""The harness' words, one sentence each: the CLI's help, the dashboard's tooltips and docs/glossary.md say the
same (tests/harness/test_glossary.py holds docs/glossary.md to these sentences).

Groups: run states (what happened to a run), verdicts (what ``harness check`` and JUnit say of it),
consistency levels (how close it came to its reference run), the words around them and those of speed and scaling.
"""
from __future__ import annotations

#: run states (harness.store.models.Run.State), in the order a run goes through them (thesis 4.5)
STATES = {
    "not executed": "The run is known (its run configuration was found) but has not been executed yet.",
    "executed": "The engine ran and exited; its output is not post-processed yet.",
    "failed": "The run did not complete: non-zero exit code, signal, timeout, non-finite values, missing output, "
              "an expectation not met, a failed stability check, or its build failed and it never executed "
              "(the failure reason says which).",
    "post-processed": "The run completed and its output was read into data series (thermo, plots, text files); "
                      "it is not compared with its reference run yet.",
    "version-consistency-checked": "The run's data series were compared with the reference run's by "
                                   "`harness check`; its consistency level is stored.",
    "outdated": "A result of an older build of its target: a newer build was made, so the run says nothing "
                "of the current code until it is run again.",
}

#: verdicts (harness.analysis.check.RunVerdict.status): what `harness check`, JUnit and the dashboard say of a run
VERDICTS = {
    "passed": "The run completed and is consistent with its reference run (or has no reference target), or a "
              "reviewer overruled its failure.",
    "failed": "The run failed, is inconsistent with its reference run, is stale, or was never executed "
              "(unless `--allow-missing`); a reviewer did not overrule it.",
    "not run": "The run is outdated, or was never executed and `--allow-missing` was given: no verdict on "
               "the current build (JUnit: skipped).",
}

#: consistency levels (harness.analysis.consistency), per quantity and, the worst of them, per run
LEVELS = {
    "perfect": "Every value stays within 5 % of the band around the reference: C >= 0.95.",
    "good": "Every value stays within 10 % of the band: 0.9 <= C < 0.95.",
    "inconsistent": "Some value leaves the band: C < 0.9, or the runs have different lengths, or a required "
                    "quantity is missing.",
    "not checked": "`harness check` has not compared the run with its reference run yet.",
    "no reference run": "The reference target has no run of the same test case content and run name to "
                        "compare with.",
}

#: the other words
TERMS = {
    "state": "What happened to a run: not executed, executed, failed, post-processed, "
             "version-consistency-checked or outdated.",
    "verdict": "What `harness check` says of a run, and of a target's current build as a whole: passed, failed "
               "or not run. A target fails when any of its runs fails.",
    "consistency level": "How close a run's data series came to its reference run's: perfect, good or "
                         "inconsistent (the worst quantity decides).",
    "C": "Consistency of one quantity: C = 1 - max_k 0.1 abs(x_k - x_ref,k) / eps (thesis eq. 4.4); 1 is "
         "identical, below 0.9 inconsistent.",
    "eps": "Half-width of the acceptance band around the reference trajectory: eps = 0.1 (max - min) / 2 of "
           "the reference (thesis eq. 4.2), at least a floor for flat references; run.config may set it per "
           "quantity.",
    "band": "The reference trajectory +/- eps: a run whose values stay inside it is consistent.",
    "first bad step": "The first step at which a trajectory leaves its band: early suggests a bug, late "
                      "suggests chaotic divergence.",
    "stale": "The test case changed on disk since the run: its result is of other content, so `harness check` "
             "fails it until it is run again.",
    "overruled": "A reviewer accepted a failure or an inconsistency with a reason (dashboard or admin); the "
                 "verdict passes and names the reviewer and reason, the stored level stays as computed.",
    "current build": "The build of the commit a target's revision resolves to now; counts and verdicts are "
                     "of current builds.",
    "reference target": "The target a target is compared against (the `reference` field of targets/NAME.json).",
    "reference run": "The run of the same test case content and run name by the reference target.",
    "stepping time": "Time the engine reports for its time-step loop (s), without start-up or kernel "
                     "compilation: what speed trends and comparisons use.",
    "wall time": "Time the engine process took from start to exit (s), start-up and compilation included.",
    "replaced": "A run of the same build and test case whose content changed since: a newer run took its "
                "place in counts and verdicts.",
    "words": "A text file declared under `textfiles` in run.config is compared word by word (split at white "
             "space) with the reference run's; numbers match within max(rtol abs(ref), atol).",
    "passed": VERDICTS["passed"],
    "failed": VERDICTS["failed"],
    "not run": VERDICTS["not run"],
}

#: the words of speed and scaling (harness.analysis.scaling, harness.analysis.breakdown, harness.execution.profiles)
EFFICIENCY = {
    "spread": "Noise of a run's stepping time measured by `harness run --repeat N`: (max - min) / median of its N "
              "stepping times; 0 without repeats.",
    "speed change": "A stepping-time ratio now / before that reaches 10 % (`bisect --slower F`: F - 1) and "
                    "exceeds the spread of repeated runs: slower or faster; anything less is no speed change.",
    "speedup": "S(P) = T(1) / T(P) for P cores (ranks or threads) from the stepping times T; weak scaling: "
               "P T(1) / T(P), as the work grows with P.",
    "efficiency": "Parallel efficiency E(P) = S(P) / P: 1 is perfect scaling, 0.5 means half of the added "
                  "cores' time is lost.",
    "Karp-Flatt": "Experimentally determined serial fraction e(P) = (1/S - 1/P) / (1 - 1/P) (Karp and Flatt "
                  "1990): constant when a serial part limits scaling, growing with P when overhead does.",
    "breakdown": "Where the stepping time went, in the sections pair, neighbor, communication, modify, output "
                 "and other (s; min/avg/max over MPI ranks where the code prints them).",
    "imbalance": "Load imbalance of an MPI run: max / avg over ranks of the pair time (or of the particles per "
                 "rank); 1 is perfect balance.",
    "profile": "A sampling profile of a run (`harness run --profile`: perf record -g for native codes, the "
               "phase timers of the bundled engine), folded into call stacks with their sample counts.",
    "flame graph": "A profile drawn as stacked boxes: each box a function, its width its share of the samples, "
                   "callers below callees. The differential one colours by the change of share between two "
                   "runs (red grew, blue shrank).",
}

#: the glossary's word for each consistency level as stored (``Run.consistency``, ``ConsistencyResult.level``): the
#: CLI, JUnit and the dashboard print these, never the stored codes; length mismatch and missing quantities
#: are inconsistent in the glossary's sense
LEVEL_WORDS = {"perfect": "perfect", "good": "good", "inconsistent": "inconsistent", "no_reference": "no reference run",
               "": "not checked", "length_mismatch": "length mismatch", "missing": "missing"}


def level_word(level: str | None) -> str:
    """The glossary's word for a stored consistency level ("no_reference" -> "no reference run")."""
    return LEVEL_WORDS.get(level or "", level or "")


#: every word with its sentence, for tooltips ("failed" is the verdict's sentence: the state's is in STATES)
ALL = {**STATES, **LEVELS, **TERMS, **EFFICIENCY}
#: the sections of docs/glossary.md
SECTIONS = {"Run states": STATES, "Verdicts": VERDICTS, "Consistency levels": LEVELS,
            "Other words": {k: v for k, v in TERMS.items() if k not in VERDICTS}, "Efficiency": EFFICIENCY}


def define(term: str) -> str:
    """The sentence for ``term`` (KeyError for a word the glossary lacks: a tooltip must not be empty)."""
    return ALL[term]
