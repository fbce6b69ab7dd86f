# SPDX-License-Identifier: MIT
"""The report directory: index.html (self-contained: relative links only, inline CSS, no script, no
network), figures/*.svg|png, tables/*.csv, results/*.json (each experiment's numbers and verdict) and
environment.json. The jobs' raw JSON stays in the result store, which the report names but does not
copy or link: the report is what gets published, the store is what rebuilds it."""

from __future__ import annotations

import csv
import html
import json
from pathlib import Path

from .experiments import Analysis, Experiment
from .figures import FIGURES

CSS = """
body { font-family: system-ui, sans-serif; max-width: 1200px; margin: 2em auto; padding: 0 1em; color: #222; }
h1 { font-size: 1.6em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: .2em; margin-top: 2em; }
table { border-collapse: collapse; font-size: .82em; margin: .5em 0; }
td, th { border: 1px solid #ccc; padding: .15em .5em; text-align: right; }
td:first-child, td:nth-child(2), th { text-align: left; }
.claim { display: grid; grid-template-columns: 1fr 1fr; gap: 1em; margin: .8em 0; }
.claim > div { padding: .6em .8em; border-radius: 4px; background: #f4f4f4; }
.verdict-confirmed { border-left: 6px solid #2ca02c; }
.verdict-partly { border-left: 6px solid #e6a700; }
.verdict-not { border-left: 6px solid #d62728; }
.verdict-none { border-left: 6px solid #999; }
img.figure { max-width: 100%; border: 1px solid #eee; }
code, pre { background: #f6f6f6; font-size: .85em; } pre { padding: .5em; overflow-x: auto; white-space: pre-wrap; }
.muted { color: #666; font-size: .9em; }
"""


def _verdict_class(verdict: str) -> str:
    return {"confirmed": "verdict-confirmed", "partly confirmed": "verdict-partly", "not confirmed": "verdict-not"}.get(
        verdict, "verdict-none"
    )


def _table_html(columns, rows) -> str:
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in columns)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(v))}</td>" for v in row) + "</tr>" for row in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def write_report(
    out: Path, entries: list[tuple[Experiment, Analysis, list, list]], environment: dict, store_root: Path
) -> Path:
    """entries: (experiment, analysis, [(scene, record, job file)], notes) per experiment."""
    out.mkdir(parents=True, exist_ok=True)
    for sub in ("figures", "tables", "results"):
        (out / sub).mkdir(exist_ok=True)
    sections = [_write_experiment(out, *entry, store_root) for entry in entries]
    summary_rows = [(experiment, analysis) for experiment, analysis, _, _ in entries]
    with open(out / "environment.json", "w") as f:
        json.dump(environment, f, indent=1)
    index = out / "index.html"
    index.write_text(_page(summary_rows, sections, environment))
    (out / "README.md").write_text(_markdown(summary_rows, environment))
    return index


def _write_experiment(
    out: Path, experiment: Experiment, analysis: Analysis, jobs: list, notes: list, store_root: Path
) -> str:
    """Writes the experiment's figure, table and results JSON; returns its section of index.html."""
    # Each job by its file in the store (relative to the store's root, which environment.json names).
    links = [(scene.label, path.relative_to(store_root).as_posix(), record) for scene, record, path in jobs]
    figure = None
    if analysis.table_rows:
        try:
            figure = FIGURES[experiment.id](analysis.plot, out / "figures")
        except Exception as error:  # noqa: BLE001 - a broken figure must not hide the others
            notes = notes + [f"figure failed: {type(error).__name__}: {error}"]
    with open(out / "tables" / f"{experiment.id}.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(analysis.table_columns)
        writer.writerows(analysis.table_rows)
    result = {
        "experiment": experiment.id,
        "title": experiment.title,
        "claim": experiment.claim,
        "slide": experiment.slide,
        "verdict": analysis.verdict,
        "summary": analysis.summary,
        "wrong_answers": analysis.wrong,
        "embree_wrong_answers": analysis.embree_wrong,
        "verified_runs": analysis.verified_runs,
        "notes": notes,
        "table": {"columns": analysis.table_columns, "rows": analysis.table_rows},
        "jobs": [link for _, link, _ in links],
    }
    with open(out / "results" / f"{experiment.id}.json", "w") as f:
        json.dump(result, f, indent=1)

    commands = "\n".join(
        f"# {label}\n" + "\n".join(" ".join(c["argv"]) for c in record["commands"]) for label, _, record in links
    )
    wrong = (
        f"Wrong answers of our rows (every traced ray checked against Embree, disagreements settled by the "
        f"exact arbiter): <b>{analysis.wrong}</b> over {analysis.verified_runs} verified runs; Embree's own "
        f"kernel (float, not exact): {analysis.embree_wrong}."
        if analysis.verified_runs
        else "This experiment traces no verified rays (no wrong-answer count applies)."
    )
    job_items = "".join(
        f"<li>{html.escape(label)} ({record['wall_s']:.1f} s on {html.escape(record['host'])}): "
        f"<code>{html.escape(link)}</code></li>"
        for label, link, record in links
    )
    return f"""
<h2 id="{experiment.id}">{html.escape(experiment.title)}</h2>
<div class="claim">
 <div><b>Slide</b> ({html.escape(experiment.slide)}): {html.escape(experiment.claim)}</div>
 <div class="{_verdict_class(analysis.verdict)}"><b>Verdict on these scenes: {html.escape(analysis.verdict)}.</b>
  {html.escape(analysis.summary)}</div>
</div>
<p class="muted">{html.escape(experiment.method)} {wrong}</p>
{_figure_html(experiment) if figure else "<p>(no figure: no job finished)</p>"}
{"".join(f'<p class="muted">Note: {html.escape(n)}</p>' for n in notes)}
{_table_html(analysis.table_columns, analysis.table_rows)}
<details><summary>Jobs and exact commands ({len(links)} jobs; raw JSON in the result store)</summary>
<ul>{job_items}</ul>
<pre>{html.escape(commands)}</pre></details>"""


def _figure_html(experiment: Experiment) -> str:
    name = experiment.id
    return (
        f'<a href="figures/{name}.png"><img class="figure" src="figures/{name}.svg" '
        f'alt="{html.escape(experiment.title)}"></a>'
        f'<p class="muted">Figure: <a href="figures/{name}.svg">SVG</a> · <a href="figures/{name}.png">PNG</a> · '
        f'table: <a href="tables/{name}.csv">CSV</a> · numbers: <a href="results/{name}.json">JSON</a></p>'
    )


def _job_runs_html(env: dict) -> str:
    """One line per run that produced the store's results."""
    return "".join(
        f"<b>Jobs run by:</b> <code>{html.escape(r['command'])}</code> ({r['jobs_run']} jobs, {r['wall_s']:.0f} s "
        f"wall, {html.escape(r['date'])}, scheduler {html.escape(r['scheduler'])}"
        f"{'; ' + html.escape(r['note']) if r.get('note') else ''})<br>"
        for r in env.get("job_runs", [])
    )


def _noise_html(env: dict) -> str:
    if not env.get("timing_spread"):
        return ""
    return (
        f"<p><b>Timing noise of this run:</b> the per-run speed ratio between two rows spans a median "
        f"{100 * env['timing_spread']:.0f} % of its value (min to max over the timed runs); speed differences "
        "smaller than that are not resolved here.</p>"
    )


def _page(summary_rows, sections: list[str], env: dict) -> str:
    """index.html: the run's provenance, the summary table, then each experiment's section."""
    overview = _table_html(
        ["experiment", "slide's claim", "verdict", "wrong answers"],
        [[e.title, e.claim, a.verdict, a.wrong if a.verified_runs else "-"] for e, a in summary_rows],
    )
    versions = env["versions"]
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>spacebvh: the paper, reproduced</title>
<style>{CSS}</style></head><body>
<h1>Object Partitioning Considered Harmful (Popov et al. 2009), reproduced with spacebvh</h1>
<p>Each section states a claim from the slides beside our verdict on these scenes, with the numbers. Every speed
figure is a ratio between rows of one <code>spacebvh compare</code> run: all rows' trees are built first, then the
timed runs go round robin over the rows on the same rays, so a shared machine's drift slows every row alike. Points
are the median over the timed runs of the per-run ratio; error bars span the runs (min to max). Builders keep one
colour in every figure.</p>
<p><b>Command:</b> <code>{html.escape(env["command"])}</code><br>
{_job_runs_html(env)}
<b>Profile:</b> {html.escape(env["profile"])} · <b>jobs:</b> {env["jobs_total"]} ({env["jobs_run"]} run now,
{env["jobs_cached"]} from the store) · <b>this command's wall time:</b> {env.get("wall_s", 0):.0f} s<br>
<b>Machine:</b> {html.escape(env["machine"]["cpu"])}, {env["machine"]["cores"]} cores,
{env["machine"]["memory_gib"]:.0f} GiB, {html.escape(env["machine"]["platform"])} ·
<b>spacebvh:</b> {html.escape(env["library_version"])} · <b>Python</b> {html.escape(versions["python"])},
dask {html.escape(versions.get("dask", "-"))}, matplotlib {html.escape(versions.get("matplotlib", "-"))}
· <a href="environment.json">environment.json</a> (versions, options, scenes and their hashes)</p>
{_noise_html(env)}
<h2>Summary</h2>
{overview}
{"".join(f'<p class="muted">Note: {html.escape(n)}</p>' for n in env.get("notes", []))}
{"".join(sections)}
</body></html>
"""


def _markdown(summary_rows, env: dict) -> str:
    """README.md beside index.html: the verdicts and figures where a repository browser shows them."""
    lines = [
        "# Popov et al. 2009, reproduced with spacebvh",
        "",
        "Generated by `spacebvh-reproduce`; open [index.html](index.html) for the full report (tables, exact "
        "commands; each job's raw JSON stays in the result store, which rebuilds the report).",
        "",
        f"- Command: `{env['command']}`",
        *[
            f"- Jobs run by `{r['command']}`: {r['jobs_run']} jobs in {r['wall_s']:.0f} s wall ({r['date']}, "
            f"scheduler {r['scheduler']}{'; ' + r['note'] if r.get('note') else ''})"
            for r in env.get("job_runs", [])
        ],
        f"- This report: written in {env.get('wall_s', 0):.0f} s by the command above ({env['jobs_run']} jobs run "
        f"by it, {env['jobs_cached']} taken from the store)",
        *(
            [
                "- Timing noise: the per-run speed ratio between two rows spans a median "
                f"{100 * env['timing_spread']:.0f} % of its value; smaller speed differences are not resolved by "
                "this run"
            ]
            if env.get("timing_spread")
            else []
        ),
        f"- Machine: {env['machine']['cpu']}, {env['machine']['cores']} cores; spacebvh {env['library_version']} "
        f"(git {env.get('git', '-')})",
        "",
        "| experiment | slide's claim | verdict | our numbers | wrong answers |",
        "|---|---|---|---|---:|",
    ]
    for e, a in summary_rows:
        cell = lambda text: str(text).replace("|", "\\|").replace("\n", " ")  # noqa: E731
        lines.append(
            f"| [{cell(e.title)}](index.html#{e.id}) | {cell(e.claim)} | **{a.verdict}** | {cell(a.summary)} | "
            f"{a.wrong if a.verified_runs else '-'} |"
        )
    for e, a in summary_rows:
        if a.table_rows:
            lines += [
                "",
                f"## {e.title}",
                "",
                f"**Verdict: {a.verdict}.** {a.summary}",
                "",
                f"![{e.title}](figures/{e.id}.svg)",
                "",
                f"Table: [tables/{e.id}.csv](tables/{e.id}.csv)",
            ]
    return "\n".join(lines) + "\n"
