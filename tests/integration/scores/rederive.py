"""Re-derives ssl evaluate's figures from a truth and a JSON result with events, by the
rules docs/guide.md states, independently of the Rust code: per source the mean 3-D
error of the rows in frames wholly inside its intervals that are nearer to it than to
any other source heard within the frame (interval plus tail); rows in frames that
overlap no interval plus tail are false; a true interval is recalled by the written
event within 10 deg that overlaps it most, whose onset error is |start - interval start|.
Usage: python3 rederive.py TRUTH.json RESULT.json TAIL_S"""
import json, math, sys
truth = json.load(open(sys.argv[1])); res = json.load(open(sys.argv[2])); tail = float(sys.argv[3])
rows, events = res["detections"], res.get("events", [])
hop = rows[0]["time_s"] / (rows[0]["frame"] + 1)


def unit(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


def angle(a, b):
    a, b = unit(a), unit(b)
    return math.degrees(math.acos(max(-1.0, min(1.0, sum(x * y for x, y in zip(a, b))))))
src = [([s["x"], s["y"], s["z"]], s["active"]) for s in truth["sources"]]
inside = lambda t, iv: any(a - 1e-9 <= t - hop and t + hop <= b + 1e-9 for a, b in iv)
heard = lambda t, iv: any(a < t + hop and b + tail > t - hop for a, b in iv)
out = {"mean_error_deg": [], "false_detections": 0, "events": len(events), "recalled": 0, "onsets": []}
for i, (d, iv) in enumerate(src):
    errs = []
    for r in rows:
        v, t = [r["x"], r["y"], r["z"]], r["time_s"]
        e = angle(v, d)
        if inside(t, iv) and all(j == i or not heard(t, iv2) or angle(v, d2) > e for j, (d2, iv2) in enumerate(src)):
            errs.append(e)
    out["mean_error_deg"].append(sum(errs) / len(errs))
    for a, b in iv:
        near = [e for e in events if e["start_s"] <= b + tail and e["end_s"] >= a and angle([e["x"], e["y"], e["z"]], d) < 10]
        if near:
            best = max(near, key=lambda e: min(e["end_s"], b + tail) - max(e["start_s"], a))
            out["recalled"] += 1
            out["onsets"].append(abs(best["start_s"] - a))
out["false_detections"] = sum(1 for r in rows if not any(heard(r["time_s"], iv) for _, iv in src))
out["onset_error_s"] = sum(out.pop("onsets")) / max(1, out["recalled"])
print(json.dumps(out))
