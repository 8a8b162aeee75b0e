#!/usr/bin/env python3
"""The WAN benchmark's report: pairs each workload's `auto` and `full` run records (written
by `meshflow submit --report`) and writes report.json and paper-shaped tables in report.md.

T_i is the slowest receiving host's download of step i's result, U_i its apply time; IB is
the input broadcast (until every plan host held the input)."""

import argparse
import datetime
import json
import os
import platform
from pathlib import Path

WORKFLOWS = {
    "repair": "RSC → LS(1) → HF → RDT",
    "while": "WHILE normal-instability > t DO LS(1)",
    "global": "AN → LS(cot) → WHILE normal-instability > t DO LS(cot)",
}
ABBREVIATIONS = {
    "remove-smallest-components": "RSC",
    "laplacian-smoothing": "LS(1)",
    "fill-holes": "HF",
    "remove-degenerate-triangles": "RDT",
    "normal-instability": "NI",
    "add-noise": "AN",
}


def kb(size):
    return None if size is None else round(size / 1024, 1)


def slowest(transfers, field):
    return max((t[field] for t in transfers), default=0.0)


def timing(step):
    return {
        "task_ms": round(step["compute_ms"], 1),
        "transfer_ms": round(slowest(step["transfers"], "download_ms"), 1),
        "update_ms": round(slowest(step["transfers"], "apply_ms"), 1),
        "via": sorted({t["via"] for t in step["transfers"]}),
    }


def receivers(step):
    """What each receiving host was asked to take (auto: the cost model's choice), what it
    used, what the model expected each way, and what it took."""
    rows = []
    for t in step["transfers"]:
        estimates = t.get("estimates") or {}
        rows.append({
            "host": t["host"].removeprefix("http://").rsplit(":", 1)[0],
            "asked": t.get("asked", t["via"]),
            "via": t["via"],
            "estimates_ms": {k.removesuffix("_ms"): round(v, 1) for k, v in estimates.items()},
            "actual_ms": round(t["finished_ms"] - t["started_ms"], 1),
            "bytes": t["bytes"],
            "fallback": t["fallback"],
            "error": t["error"],
        })
    return rows


def broadcast(record):
    """Input broadcast: its time and the slowest host's download rate."""
    hosts = record["broadcast"]["hosts"]
    rates = [h["bytes"] * 8 / h["download_ms"] / 1e3 for h in hosts if h["download_ms"] > 0]
    return {
        "ms": round(record["broadcast"]["ms"], 1),
        "bytes": max(h["bytes"] for h in hosts),
        "hosts": len(hosts),
        "min_mbit_s": round(min(rates), 3) if rates else None,
    }


def floor_ms(record):
    """The least the run could take with no overhead at all: the input broadcast, every
    task, and each replay the next task waited for on its host (re-running a step where it
    is needed is work the plan chose, not overhead)."""
    steps = record["steps"]
    total = record["broadcast"]["ms"] + sum(s["compute_ms"] for s in steps)
    for step, following in zip(steps, steps[1:]):
        total += sum(t["apply_ms"] for t in step["transfers"]
                     if t["via"] == "replay" and t["host"] == following["host"])
    return total


def settled_s(record):
    """When the record settled (the result packed where it is held), if it says."""
    settled = record.get("settled_ms")
    return round(settled / 1e3, 3) if settled is not None else None


def pair(mesh, workflow, auto, full):
    if len(auto["steps"]) != len(full["steps"]):
        raise SystemExit(f"{mesh} {workflow}: auto ran {len(auto['steps'])} steps, full {len(full['steps'])}")
    steps = []
    for a, f in zip(auto["steps"], full["steps"]):
        steps.append({
            "index": a["index"],
            "path": a["path"],
            "service": a["service"],
            "host": a["host"].removeprefix("http://").rsplit(":", 1)[0],
            "value": a["value"],
            "correction_kb": kb(a["correction_bytes"] if a["correction_bytes"] is not None else f["correction_bytes"]),
            # What the producer estimated the log at when it answered (auto chose by it);
            # none when the estimate was never replaced by the real size.
            "correction_estimate_kb": kb(a.get("correction_estimate_bytes")),
            "correction_sizes": (a.get("correction_estimate_bytes"), a["correction_bytes"]),
            "replay_bytes": a.get("replay_bytes"),
            "receivers": receivers(a),
            "full_kb": kb(f["full_bytes"] if f["full_bytes"] is not None else a["full_bytes"]),
            "auto": timing(a),
            "full": timing(f),
        })
    auto_s, full_s = auto["total_ms"] / 1e3, full["total_ms"] / 1e3
    return {
        "mesh": mesh,
        "workflow": workflow,
        "vertices": auto["input"]["vertices"],
        "triangles": auto["input"]["triangles"],
        "same_result": auto["result"]["hash"] == full["result"]["hash"],
        "auto_total_s": round(auto_s, 3),
        "full_total_s": round(full_s, 3),
        "full_over_auto": round(full_s / auto_s, 3),
        # Settled: the result also packed on its two holders, after the run's end.
        "auto_settled_s": settled_s(auto),
        "auto_floor_s": round(floor_ms(auto) / 1e3, 3),
        "auto_over_floor": round(auto["total_ms"] / floor_ms(auto), 3),
        "broadcast": {"auto": broadcast(auto), "full": broadcast(full)},
        "warnings": auto["warnings"] + full["warnings"],
        "steps": steps,
    }


def estimates_within_2x(runs):
    """How many edit-log estimates of the auto runs were within 2× of the real size."""
    pairs = [s["correction_sizes"] for run in runs for s in run["steps"]
             if all(s["correction_sizes"])]
    within = sum(1 for est, actual in pairs if 0.5 <= est / actual <= 2.0)
    return within, len(pairs)


def read_records(directory):
    """Run records named MESH.WORKFLOW.VARIANT.json, by (mesh, workflow) and variant."""
    records = {}
    for path in sorted(Path(directory).glob("*.json")):
        mesh, workflow, variant = path.name[: -len(".json")].rsplit(".", 2)
        record = json.loads(path.read_text())
        if record["status"] != "completed":
            raise SystemExit(f"{path}: run {record['status']}: {record['error']}")
        records.setdefault((mesh, workflow), {})[variant] = record
    return records


def load_placements(directory):
    """The same workload placed by link and by load: totals side by side."""
    rows = []
    for (mesh, workflow), runs in read_records(directory).items():
        link, load = runs["link"], runs["load"]
        hosts = lambda r: sorted({s["host"].removeprefix("http://").rsplit(":", 1)[0] for s in r["steps"]})
        rows.append({
            "mesh": mesh,
            "workflow": workflow,
            "link_total_s": round(link["total_ms"] / 1e3, 3),
            "load_total_s": round(load["total_ms"] / 1e3, 3),
            "link_over_load": round(link["total_ms"] / load["total_ms"], 3),
            "link_hosts": hosts(link),
            "load_hosts": hosts(load),
            "same_result": link["result"]["hash"] == load["result"]["hash"],
        })
    return rows


def load_runs(directory):
    records = read_records(directory)
    return [pair(mesh, wf, modes["auto"], modes["full"]) for (mesh, wf), modes in records.items()]


def link_check(path, rates):
    rows = []
    for line, rate in zip(Path(path).read_text().splitlines(), rates):
        address, size, seconds = line.split("\t")
        mbit = int(size) * 8 / float(seconds) / 1e6
        rows.append({"host": address, "bytes": int(size), "seconds": float(seconds), "link_mbit": rate,
                     "mbit_s": round(mbit, 3), "of_link": round(mbit / rate, 3)})
    return rows


def machine():
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, Linux {platform.release()}"


def cell(value, digits=0):
    return "–" if value is None else f"{value:,.{digits}f}"


def markdown(report):
    rates = report["link_mbit"]
    rate = min(rates)
    lines = [
        f"# WAN benchmark — {report['date']}",
        "",
        f"Machine: {report['machine']}. Every host behind its own link of "
        f"{', '.join(f'{r:g}' for r in rates)} Mbit/s "
        f"({report['delay_ms']} ms one-way delay), shaped with tc in a private network namespace.",
        "",
        "## Link check (2 MB download into each host address)",
        "",
        "| host | link Mbit/s | seconds | Mbit/s | of link |",
        "|---|---:|---:|---:|---:|",
    ]
    for row in report["link_check"]:
        lines.append(f"| {row['host']} | {row['link_mbit']:g} | {row['seconds']:.2f} | {row['mbit_s']:.2f} | {row['of_link']:.0%} |")
    lines += [
        "",
        "## Totals",
        "",
        "floor: the input broadcast, every task and each replay the next task waited for; "
        "what auto took beyond it is the engine's and the transfers' overhead. A run ends when two "
        "hosts hold its result (hash checked); settled: both have packed it too, after the end.",
        "",
        "| mesh | workflow | V | T | IB KB | IB rate (of link) | auto s | auto settled s | full s | full / auto "
        "| auto ≤ 0.5× full | floor s | auto / floor |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|:---:|---:|---:|",
    ]
    for run in report["runs"]:
        ib = run["broadcast"]["auto"]
        ib_rate = min(r for r in (run["broadcast"]["auto"]["min_mbit_s"], run["broadcast"]["full"]["min_mbit_s"]) if r)
        lines.append(
            f"| {run['mesh']} | {run['workflow']} | {run['vertices']:,} | {run['triangles']:,} "
            f"| {cell(kb(ib['bytes']))} | {ib_rate:.2f} Mbit/s ({ib_rate / rate:.0%}) "
            f"| {run['auto_total_s']:.1f} | {cell(run['auto_settled_s'], 1)} | {run['full_total_s']:.1f} "
            f"| {run['full_over_auto']:.2f} "
            f"| {'yes' if run['auto_total_s'] <= 0.5 * run['full_total_s'] else 'no'} "
            f"| {run['auto_floor_s']:.1f} | {run['auto_over_floor']:.2f} |"
        )
    within, estimated = estimates_within_2x(report["runs"])
    if estimated:
        lines += ["", f"Edit-log size estimates (what `auto` chose by) within 2× of the real size: "
                      f"{within} of {estimated} ({within / estimated:.0%})."]
    if report["placements"]:
        lines += [
            "",
            "## Host selection: by link and load (`placement: link`) against by load alone",
            "",
            "| mesh | workflow | link s | load s | link / load | hosts (link) | hosts (load) | same mesh |",
            "|---|---|---:|---:|---:|---|---|:---:|",
        ]
        for row in report["placements"]:
            lines.append(
                f"| {row['mesh']} | {row['workflow']} | {row['link_total_s']:.2f} | {row['load_total_s']:.2f} "
                f"| {row['link_over_load']:.2f} | {', '.join(row['link_hosts'])} | {', '.join(row['load_hosts'])} "
                f"| {'yes' if row['same_result'] else 'NO'} |"
            )
    for run in report["runs"]:
        lines += [
            "",
            f"## {run['mesh']} — {WORKFLOWS.get(run['workflow'], run['workflow'])}",
            "",
            "Times in ms; T_i = slowest download of the step's result by a host with work left, "
            "U_i = slowest apply. auto moves corrections where they are smaller, full moves `.mfm` meshes.",
            "",
            "| step | task | host | correction KB | est. KB | full KB | task (auto) | T_i (auto) | U_i (auto) "
            "| task (full) | T_i (full) | U_i (full) |",
            "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
            f"| IB | input | {run['broadcast']['auto']['hosts']} hosts | | | {cell(kb(run['broadcast']['auto']['bytes']), 1)} "
            f"| | {cell(run['broadcast']['auto']['ms'])} | | | {cell(run['broadcast']['full']['ms'])} | |",
        ]
        for step in run["steps"]:
            name = ABBREVIATIONS.get(step["service"], step["service"])
            if step["value"] is not None:
                name += f" = {step['value']:.3g}" if isinstance(step["value"], float) else f" = {step['value']}"
            a, f = step["auto"], step["full"]
            lines.append(
                f"| {step['index']} | {name} | {step['host']} | {cell(step['correction_kb'], 1)} "
                f"| {cell(step['correction_estimate_kb'], 1)} | {cell(step['full_kb'], 1)} | {cell(a['task_ms'])} | {cell(a['transfer_ms'])} "
                f"| {cell(a['update_ms'])} | {cell(f['task_ms'])} | {cell(f['transfer_ms'])} | {cell(f['update_ms'])} |"
            )
        lines.append(
            f"| total | | | | | | **{run['auto_total_s']:.2f} s** | | | **{run['full_total_s']:.2f} s** | | |"
        )
        lines.append("")
        lines.append(f"full / auto = **{run['full_over_auto']:.2f}**; same final mesh in both modes: "
                     f"{'yes' if run['same_result'] else 'NO'}.")
        for warning in run["warnings"]:
            lines.append(f"Warning: {warning}")
        lines += [
            "",
            "What each receiver got in `auto`, and why (the cost model's estimates in ms, then the time it took):",
            "",
            "| step | receiver | asked | used | edits est. | replay est. | full est. | took ms | bytes | fallback |",
            "|---|---|---|---|---:|---:|---:|---:|---:|---|",
        ]
        for step in run["steps"]:
            for r in step["receivers"]:
                est = r["estimates_ms"]
                lines.append(
                    f"| {step['index']} | {r['host']} | {r['asked']} | {r['via']} | {cell(est.get('correction'), 1)} "
                    f"| {cell(est.get('replay'), 1)} | {cell(est.get('full'), 1)} | {cell(r['actual_ms'], 1)} "
                    f"| {r['bytes']:,} | {r['fallback'] or r['error'] or ''} |"
                )
    return "\n".join(lines) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", required=True)
    parser.add_argument("--link-check", required=True)
    parser.add_argument("--placement-runs", required=True)
    parser.add_argument("--rates", required=True, help="Mbit/s of each host's link, comma-separated")
    parser.add_argument("--delay", type=int, required=True)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    report = {
        "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "machine": machine(),
        "link_mbit": [float(r) for r in args.rates.split(",")],
        "delay_ms": args.delay,
        "link_check": link_check(args.link_check, [float(r) for r in args.rates.split(",")]),
        "runs": load_runs(args.runs),
        "placements": load_placements(args.placement_runs),
    }
    out = Path(args.out)
    (out / "report.json").write_text(json.dumps(report, indent=2, ensure_ascii=False) + "\n")
    (out / "report.md").write_text(markdown(report))


if __name__ == "__main__":
    main()
