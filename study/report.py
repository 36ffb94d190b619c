#!/usr/bin/env python3
"""Plots the CSV files of cutsim_study into DOCS/study/*.png and writes DOCS/study.md.

usage: report.py --data DIR --docs DOCS [--mode quick|full]
"""
import argparse
import csv
import math
import os
from collections import OrderedDict, defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def read(data, name):
    with open(os.path.join(data, name), newline="") as f:
        return list(csv.DictReader(f))


def num(s):
    try:
        return float(s)
    except ValueError:
        return float("nan")


def fmt(v, digits=3):
    if isinstance(v, str):
        return v
    if v != v:
        return "n/a"
    if v == 0:
        return "0"
    if abs(v) < 1e-3 or abs(v) >= 1e5:
        return f"{v:.{digits - 1}e}"
    return f"{v:.{digits}g}"


def pareto_front(rows):
    """The runs no other run beats in both wall time and error, by increasing time."""
    pts = sorted(rows, key=lambda r: (num(r["seconds"]), num(r["error"])))
    front, best = [], float("inf")
    for r in pts:
        if num(r["error"]) < best:
            front.append(r)
            best = num(r["error"])
    return front


def table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        out.append("| " + " | ".join(fmt(c) for c in r) + " |")
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", required=True)
    ap.add_argument("--docs", required=True)
    ap.add_argument("--mode", default="quick")
    a = ap.parse_args()
    figs = os.path.join(a.docs, "study")
    os.makedirs(figs, exist_ok=True)
    summary = {r["key"]: num(r["value"]) for r in read(a.data, "summary.csv")}

    # ---- a. cylinder ----
    cyl = read(a.data, "cylinder.csv")
    rates = read(a.data, "cylinder_rates.csv")
    series = OrderedDict()
    for r in cyl:
        series.setdefault((r["mesh"], r["axis"], r["model"]), []).append(
            (num(r["h"]), num(r["rel_error"]), num(r["ratio"])))
    fig, axes = plt.subplots(1, 3, figsize=(17, 5), sharey=True)
    for ax, model in zip(axes, ["springs", "springs_signed", "dihedral"]):
        for (mesh, axis, m), pts in series.items():
            if m != model:
                continue
            ax.loglog([p[0] for p in pts], [max(p[1], 1e-6) for p in pts], "o-",
                      label=f"{mesh}, {axis}")
        ax.set_title(f"{model}: |E / E_c - 1|, rolled to r = 1", fontsize=10)
        ax.set_xlabel("h (edge length)")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("relative energy error (values < 1e-6 drawn at 1e-6)")
    axes[2].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(figs, "cylinder_error.png"), dpi=110)
    plt.close(fig)

    cyl_rows = []
    by = {(r["mesh"], r["axis"], r["model"]): r for r in rates}
    for (mesh, axis, model) in by:
        if model != "springs":
            continue
        s, d = by[(mesh, axis, "springs")], by[(mesh, axis, "dihedral")]
        g = by[(mesh, axis, "springs_signed")]
        cyl_rows.append([mesh, axis, num(s["finest_ratio"]), num(s["slope"]),
                         num(g["finest_ratio"]), num(g["slope"]),
                         num(d["finest_ratio"]), num(d["slope"])])

    # ---- b. fold ----
    fold = read(a.data, "fold.csv")
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.5))
    th = [num(r["theta"]) for r in fold]
    ax[0].plot(th, [num(r["exact"]) for r in fold], "k-", label="exact k l theta^2 / (3 (hA + hB))")
    ax[0].plot(th, [num(r["springs"]) for r in fold], "--", label="linear springs")
    ax[0].plot(th, [num(r["dihedral"]) for r in fold], ":", lw=3, label="dihedral")
    ax[0].set_xlabel("fold angle theta (rad)")
    ax[0].set_ylabel("energy of hinge H (k = 1)")
    ax[0].legend()
    ax[0].grid(alpha=0.3)
    ax[1].semilogy(th, [max(num(r["rel_error_springs"]), 1e-17) for r in fold], label="linear springs")
    ax[1].semilogy(th, [max(num(r["rel_error_dihedral"]), 1e-17) for r in fold], label="dihedral")
    ax[1].axhline(0.1, color="gray", ls=":")
    ax[1].axhline(0.01, color="gray", ls=":")
    ax[1].set_xlabel("fold angle theta (rad)")
    ax[1].set_ylabel("relative energy error")
    ax[1].legend()
    ax[1].grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(figs, "fold_error.png"), dpi=110)
    plt.close(fig)
    fold_rows = []
    for target in [0.1, 0.25, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0]:
        r = min(fold, key=lambda q: abs(num(q["theta"]) - target))
        fold_rows.append([num(r["theta"]), num(r["theta"]) * 180 / math.pi, num(r["exact"]),
                          num(r["springs"]), num(r["dihedral"]), num(r["rel_error_springs"])])
    fold_grid = read(a.data, "fold_grid.csv")
    fg_rows = [[num(r["r"]), num(r["hinge_angle"]), num(r["springs"]), num(r["dihedral"]),
                num(r["ratio"])] for r in fold_grid]

    # ---- c. rest forces ----
    rf = read(a.data, "rest_forces.csv")
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for kind in OrderedDict((r["mesh"], 1) for r in rf):
        rows = [r for r in rf if r["mesh"] == kind]
        n = [num(r["n"]) for r in rows]
        ax.semilogy(n, [max(num(r["scaled_unsigned"]), 1e-16) for r in rows], "o-",
                    label=f"{kind}: unsigned")
        ax.semilogy(n, [max(num(r["scaled_signed"]), 1e-16) for r in rows], "s--",
                    label=f"{kind}: signed")
    ax.set_xlabel("vertices per side n")
    ax.set_ylabel("max |f| at rest * h / k (floor 1e-16)")
    ax.set_title("rest forces of flat meshes (dihedral: exactly 0)")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(figs, "rest_forces.png"), dpi=110)
    plt.close(fig)
    rf_rows = [[r["mesh"], int(num(r["n"])), int(num(r["hinges"])), int(num(r["nonconvex"])),
                int(num(r["signed_fallbacks"])), num(r["scaled_unsigned"]),
                num(r["scaled_signed"]), num(r["scaled_dihedral"])] for r in rf]

    # ---- d. cantilever ----
    ca = read(a.data, "cantilever.csv")
    fig, ax = plt.subplots(figsize=(7, 4.5))
    cseries = OrderedDict()
    for r in ca:
        cseries.setdefault((r["mesh"], r["model"]), []).append(r)
    for (mesh, model), rows in cseries.items():
        ax.semilogx([num(r["h"]) for r in rows], [num(r["ratio_plate"]) for r in rows],
                    "o-" if model == "springs" else "x:", label=f"{mesh}, {model}")
    ax.axhline(1.0, color="k", ls=":", label="plate: F L^3 / (3 D b)")
    ax.axhline(9 / 8, color="gray", ls="--", label="narrow beam, nu = -1/3")
    ax.set_xlabel("h")
    ax.set_ylabel("tip deflection / (F L^3 / (3 D b))")
    ax.set_title("cantilever strip L = 1, b = 0.25, D = k / 3")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(figs, "cantilever.png"), dpi=110)
    plt.close(fig)
    ca_rows = [[r["mesh"], r["model"], int(num(r["nx"])), num(r["h"]), num(r["ratio_plate"]),
                num(r["ratio_beam"])] for r in ca]

    # ---- e. error against wall time ----
    pa = read(a.data, "pareto.csv")
    refs = {(r["scenario"], r["bending"]): r for r in read(a.data, "reference.csv")}
    colors = {"explicit-euler": "tab:gray", "implicit-euler": "tab:blue", "bdf2": "tab:green",
              "newton": "tab:red"}
    markers = {"-": "o", "cg20": "v", "cg100": "s", "cholmod": "D"}
    styles = {"-": "-", "cg20": ":", "cg100": "--", "cholmod": "-"}
    panels = [(s, b) for s in ("hanging", "cut") for b in ("springs", "dihedral")
              if any(r["scenario"] == s and r["bending"] == b for r in pa)]
    fronts = {}
    fig, axes = plt.subplots(2, 2, figsize=(15, 11))
    for ax in list(axes.flat)[len(panels):]:
        ax.set_visible(False)
    for ax, (scen, bend) in zip(axes.flat, panels):
        rows = [r for r in pa if r["scenario"] == scen and r["bending"] == bend]
        ok = [r for r in rows if r["stable"] == "1"]
        series = OrderedDict()
        for r in ok:
            series.setdefault(r["method"], []).append(r)
        for name, rs in series.items():
            integ, solv = rs[0]["integrator"], rs[0]["solver"]
            ax.loglog([num(r["seconds"]) for r in rs], [num(r["error"]) for r in rs],
                      marker=markers[solv], ls=styles[solv], color=colors[integ], ms=5, lw=1,
                      label=name)
        front = pareto_front(ok)
        fronts[(scen, bend)] = front
        ax.step([num(r["seconds"]) for r in front], [num(r["error"]) for r in front], "k-",
                where="post", lw=2.5, alpha=0.35, zorder=0, label="Pareto front")
        for r in front:
            ax.plot(num(r["seconds"]), num(r["error"]), "o", ms=13, mfc="none", mec="k", mew=1.2)
            ax.annotate(f"{num(r['dt']):g}", (num(r["seconds"]), num(r["error"])), fontsize=7,
                        xytext=(6, 4), textcoords="offset points")
        blown = [r for r in rows if r["stable"] != "1"]
        note = "; ".join(f"{r['method']} blows up at dt = {num(r['dt']):g}" for r in blown)
        ref = refs[(scen, bend)]
        ax.set_title(f"{scen} cloth, {bend}: error at T = {num(ref['T']):g} s vs BDF2+CHOLMOD "
                     f"dt = {num(ref['dt']):.3g}", fontsize=10)
        if note:
            ax.text(0.02, 0.02, note, transform=ax.transAxes, fontsize=7, color="tab:gray")
        ax.set_xlabel("wall time of the run (s)")
        ax.set_ylabel("max position error (m)")
        ax.grid(True, which="both", alpha=0.3)
    axes.flat[min(1, len(panels) - 1)].legend(fontsize=7, ncol=2, loc="upper right")
    fig.suptitle("error against cost (circled: the Pareto front, labels: dt)")
    fig.tight_layout()
    fig.savefig(os.path.join(figs, "pareto.png"), dpi=100)
    plt.close(fig)

    front_rows = []
    for (scen, bend) in panels:
        for r in fronts[(scen, bend)]:
            front_rows.append([scen, bend, r["method"], num(r["dt"]), num(r["seconds"]),
                               num(r["error"]), int(num(r["flagged_steps"]))])
    all_rows = [[r["scenario"], r["bending"], r["method"], num(r["dt"]), int(num(r["steps"])),
                 num(r["ms_per_step"]), num(r["seconds"]), num(r["error"]),
                 "yes" if r["stable"] == "1" else "NO: " + r["failure"][:60],
                 int(num(r["flagged_steps"])),
                 (num(r["newton_iterations"]) / num(r["steps"])) if r["integrator"] == "newton"
                 else "",
                 (num(r["linear_iterations"]) / max(1.0, num(r["newton_iterations"]) or num(r["steps"])))
                 if r["solver"] in ("cg20", "cg100") else ""]
                for r in pa]
    ref_rows = [[r["scenario"], r["bending"], int(num(r["vertices"])), num(r["dt"]),
                 num(r["seconds"]), num(r["estimated_error"])] for r in refs.values()]

    def best_under(scen, bend, tol, integrators=None):
        """The cheapest stable run with an error below tol (from the measurements)."""
        rs = [r for r in pa if r["scenario"] == scen and r["bending"] == bend and r["stable"] == "1"
              and num(r["error"]) <= tol and (integrators is None or r["integrator"] in integrators)]
        return min(rs, key=lambda r: num(r["seconds"])) if rs else None

    def desc(r):
        return "none" if r is None else f"{r['method']} dt {num(r['dt']):g} ({num(r['seconds']):.2g} s, {num(r['error']):.2g} m)"

    # The error of each implicit method at the largest dt (real-time use), per panel.
    def at_dt(scen, bend, method, dt):
        for r in pa:
            if (r["scenario"], r["bending"], r["method"]) == (scen, bend, method) and \
                    abs(num(r["dt"]) - dt) < 1e-12 and r["stable"] == "1":
                return r
        return None
    dts_impl = sorted({num(r["dt"]) for r in pa if r["integrator"] != "explicit-euler"})
    big_dt = dts_impl[-1] if dts_impl else float("nan")
    big_rows = []
    for (scen, bend) in panels:
        row = [scen, bend]
        for m in ("implicit-euler/cg20", "implicit-euler/cholmod", "bdf2/cg20", "bdf2/cholmod",
                  "newton/cg20", "newton/cholmod"):
            r = at_dt(scen, bend, m, big_dt)
            row.append(f"{num(r['error']):.3g} m / {num(r['seconds']):.2g} s" if r else "n/a")
        big_rows.append(row)
    need_rows = []
    for (scen, bend) in panels:
        need_rows.append([scen, bend, desc(best_under(scen, bend, 1e-2)),
                          desc(best_under(scen, bend, 1e-2, ("implicit-euler", "bdf2", "newton"))),
                          desc(best_under(scen, bend, 1e-1, ("implicit-euler", "bdf2", "newton")))])
    ex_limits = {(scen, bend): summary.get(f"explicit_limit_{scen}_{bend}", float("nan"))
                 for (scen, bend) in panels}

    # ---- f. order of accuracy ----
    od = read(a.data, "order.csv")
    ofit = read(a.data, "order_fit.csv")
    fig, ax = plt.subplots(figsize=(7.5, 5))
    oseries = OrderedDict()
    for r in od:
        oseries.setdefault((r["method"], r["stiffness"]), []).append(r)
    fitd = {(r["method"], r["stiffness"]): r for r in ofit}
    ostyle = {("bdf2", "exact"): ("tab:green", "o-"), ("bdf2", "default"): ("tab:green", "x:"),
              ("implicit-euler", "exact"): ("tab:blue", "o-"),
              ("implicit-euler", "default"): ("tab:blue", "x:")}
    for key, rs in oseries.items():
        f = fitd[key]
        c, st_ = ostyle[key]
        ax.loglog([num(r["dt"]) for r in rs], [num(r["error"]) for r in rs], st_, color=c,
                  label=f"{key[0]}, K {key[1]}: slope {num(f['slope']):.2f}")
    # Reference slopes through the finest BDF2 / implicit Euler points.
    for key, p in ((("bdf2", "exact"), 2), (("implicit-euler", "exact"), 1)):
        rs = oseries.get(key, [])
        if rs:
            d0, e0 = num(rs[-1]["dt"]), num(rs[-1]["error"])
            xs = [num(r["dt"]) for r in rs]
            ax.loglog(xs, [e0 * (x / d0) ** p for x in xs], color="k", lw=0.8, alpha=0.4,
                      ls="--")
    ax.axhline(summary.get("order_ref_error", float("nan")), color="gray", ls=":",
               label="reference's estimated error")
    ax.set_xlabel("dt (s)")
    ax.set_ylabel("max position error at t = 0.5 s (m)")
    ax.set_title(f"hanging cloth ({int(summary.get('order_n', 0)) ** 2} vertices, springs): "
                 f"order of accuracy\nreference BDF2 + CHOLMOD, exact K, dt = "
                 f"{summary.get('order_ref_dt', float('nan')):.3g}; dashed: slopes 2 and 1",
                 fontsize=10)
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(figs, "order.png"), dpi=110)
    plt.close(fig)
    odts = sorted({num(r["dt"]) for r in od}, reverse=True)
    order_rows = []
    for key, rs in oseries.items():
        d = {num(r["dt"]): num(r["error"]) for r in rs}
        local = [math.log(d[odts[i]] / d[odts[i + 1]]) / math.log(odts[i] / odts[i + 1])
                 for i in range(len(odts) - 1) if odts[i] in d and odts[i + 1] in d]
        order_rows.append([key[0], key[1]] + [d.get(x, float("nan")) for x in odts] +
                          [" / ".join(f"{v:.2f}" for v in local), num(fitd[key]["slope"])])
    fit_lo = min(num(r["dt_min"]) for r in ofit)
    fit_hi = max(num(r["dt_max"]) for r in ofit)
    slope = {k: num(v["slope"]) for k, v in fitd.items()}

    # ---- g. Newton ----
    nw = read(a.data, "newton.csv")
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.8), sharey=True)
    def linear_exact(setting):
        """Steps whose exact-Hessian run ends linearly: Newton fell back to the default stiffness."""
        return len({r["step"] for r in nw if r["setting"] == setting and r["stiffness"] == "exact"
                    and num(r["terminal_order"]) < 1.3})
    nseries = OrderedDict()
    for r in nw:
        nseries.setdefault((r["setting"], r["stiffness"], int(num(r["step"]))), []).append(r)
    for ax, setting in zip(axes, ("study", "large-dt")):
        dt = next(num(r["dt"]) for r in nw if r["setting"] == setting)
        for (s, stiff, step), rs in nseries.items():
            if s != setting:
                continue
            ax.semilogy([int(num(r["iteration"])) for r in rs], [num(r["relative"]) for r in rs],
                        "o-" if stiff == "exact" else "s--",
                        color=["tab:red", "tab:orange", "tab:purple"][step - 1] if stiff == "exact"
                        else ["tab:blue", "tab:cyan", "tab:green"][step - 1],
                        ms=4, label=f"{'exact Hessian' if stiff == 'exact' else 'Gauss-Newton'}, step {step}")
        ax.axhline(1e-10, color="gray", ls=":")
        ax.set_xlabel("Newton iteration")
        fell = linear_exact(setting)
        ax.set_title(f"dt = {dt:g} s" + (" (the study's setting)" if setting == "study" else "") +
                     f": the exact run ends linearly (fell back) in {fell} of 3 steps",
                     fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    axes[0].set_ylabel("|residual| / |first residual|")
    fig.suptitle("Newton + CHOLMOD on a dihedral fold of "
                 f"{summary.get('newton_angle_deg', float('nan')):.0f} deg, released")
    fig.tight_layout()
    fig.savefig(os.path.join(figs, "newton.png"), dpi=110)
    plt.close(fig)
    newton_rows = []
    for setting in ("study", "large-dt"):
        for step in (1, 2, 3):
            ex = nseries.get((setting, "exact", step), [])
            gn = nseries.get((setting, "gauss-newton", step), [])
            if not ex:
                continue
            newton_rows.append([
                setting, num(ex[0]["dt"]), step,
                " ".join(f"{num(r['relative']):.1e}" for r in ex), num(ex[0]["terminal_order"]),
                " ".join(f"{num(r['relative']):.1e}" for r in gn), num(gn[0]["terminal_order"]),
                "yes" if num(ex[0]["terminal_order"]) < 1.3 else "no"])

    # ---- h. cost of one step ----
    sc = read(a.data, "solver_cost.csv")
    fig, ax = plt.subplots(figsize=(7, 4.5))
    cs = OrderedDict()
    for r in sc:
        cs.setdefault(r["solver"], []).append(r)
    for name, rows in cs.items():
        ax.loglog([num(r["vertices"]) for r in rows], [1e3 * num(r["seconds_per_step"]) for r in rows],
                  "o-", label=name)
    ax.set_xlabel("vertices")
    ax.set_ylabel("ms per step")
    ax.set_title("cost of one step (explicit dt 1e-4, implicit dt 5e-3)")
    ax.legend(fontsize=7)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(figs, "solver_cost.png"), dpi=110)
    plt.close(fig)
    verts = sorted({int(num(r["vertices"])) for r in sc})
    cost_rows = []
    for name, rows in cs.items():
        d = {int(num(r["vertices"])): 1e3 * num(r["seconds_per_step"]) for r in rows}
        cost_rows.append([name] + [d.get(v, float("nan")) for v in verts])
    growth = {}
    for name, rows in cs.items():
        x = [math.log(num(r["vertices"])) for r in rows]
        y = [math.log(num(r["seconds_per_step"])) for r in rows]
        n = len(x)
        mx, my = sum(x) / n, sum(y) / n
        growth[name] = sum((p - mx) * (q - my) for p, q in zip(x, y)) / sum((p - mx) ** 2 for p in x)
    for row in cost_rows:
        row.append(growth[row[0]])

    # ---- what the measurements say, for the text and the table ----
    def run(scen, bend, method, dt):
        return at_dt(scen, bend, method, dt)

    def pick_at_big_dt(scen, bend, within=1.1):
        """At the largest dt: the cheapest implicit run whose error is within `within` of the best."""
        rs = [r for r in pa if r["scenario"] == scen and r["bending"] == bend and r["stable"] == "1"
              and r["integrator"] != "explicit-euler" and abs(num(r["dt"]) - big_dt) < 1e-12]
        if not rs:
            return None
        best = min(num(r["error"]) for r in rs)
        return min((r for r in rs if num(r["error"]) <= within * best), key=lambda r: num(r["seconds"]))

    def short(r):
        return "n/a" if r is None else f"{r['method']}, dt {num(r['dt']):g}"

    def ratio(scen, bend, m1, m2):
        """Largest error ratio m1 / m2 over the implicit time steps."""
        out = []
        for dt in dts_impl:
            r1, r2 = run(scen, bend, m1, dt), run(scen, bend, m2, dt)
            if r1 and r2 and num(r2["error"]) > 0:
                out.append(num(r1["error"]) / num(r2["error"]))
        return out
    def big_dt_choice(scen, bend):
        rs = [r for r in pa if r["scenario"] == scen and r["bending"] == bend and r["stable"] == "1"
              and r["integrator"] != "explicit-euler" and abs(num(r["dt"]) - big_dt) < 1e-12]
        if not rs:
            return "n/a"
        cheap = min(rs, key=lambda r: num(r["seconds"]))
        best = min(rs, key=lambda r: num(r["error"]))
        text = f"{cheap['method']} (the cheapest: {num(cheap['error']):.2g} m)"
        if best is not cheap:
            text += (f"; {best['method']} for {num(cheap['error']) / num(best['error']):.1f}x less "
                     f"error at {num(best['seconds']) / num(cheap['seconds']):.0f}x the cost")
        return text
    rt_springs = big_dt_choice("hanging", "springs")
    rt_dihedral = big_dt_choice("cut", "dihedral")
    ncg_best = 0
    for (sc, b) in panels:
        rs = [r for r in pa if r["scenario"] == sc and r["bending"] == b and r["stable"] == "1"
              and r["integrator"] != "explicit-euler" and abs(num(r["dt"]) - big_dt) < 1e-12]
        if rs and min(rs, key=lambda r: num(r["error"]))["method"] == "newton/cg20":
            ncg_best += 1
    acc10_dihedral = best_under("cut", "dihedral", 1e-1, ("implicit-euler", "bdf2", "newton"))
    ex_limits = {k: v for k, v in ex_limits.items() if k in panels}
    acc_springs = best_under("hanging", "springs", 1e-2)
    acc_dihedral = best_under("cut", "dihedral", 1e-2)
    acc_dihedral_impl = best_under("cut", "dihedral", 1e-2, ("implicit-euler", "bdf2", "newton"))
    cg20_vs = [x for (sc, b) in panels for m in ("implicit-euler", "bdf2")
               for x in ratio(sc, b, m + "/cg20", m + "/cholmod")]
    newton_vs_ie = [x for (sc, b) in panels for x in ratio(sc, b, "newton/cholmod", "implicit-euler/cholmod")]
    bdf2_vs_ie = [x for (sc, b) in panels for x in ratio(sc, b, "bdf2/cholmod", "implicit-euler/cholmod")]
    newton_cg_flag = [num(r["flagged_steps"]) / num(r["steps"]) for r in pa
                      if r["integrator"] == "newton" and r["solver"] == "cg20" and r["stable"] == "1"]
    front_text = []
    for (scen, bend) in panels:
        members = ", ".join(f"{r['method']} at {num(r['dt']):g}" for r in fronts[(scen, bend)])
        front_text.append(f"    - {scen} cloth, {bend}: {members}")
    unresolved = []
    for (scen, bend) in panels:
        e_ref = num(refs[(scen, bend)]["estimated_error"])
        rs = [r for r in pa if r["scenario"] == scen and r["bending"] == bend and r["stable"] == "1"
              and num(r["error"]) < 3 * e_ref]
        if rs:
            unresolved.append(f"{scen}/{bend} (reference's estimated error {e_ref:.2g} m: "
                              + ", ".join(f"{r['method']} at {num(r['dt']):g}" for r in rs) + ")")
    unresolved_text = ("Runs whose error is below three times their reference's estimated error "
                       "are not resolved by this comparison (their error is an upper bound of "
                       "the reference's uncertainty, not theirs): " + "; ".join(unresolved) + "."
                       ) if unresolved else ("Every run's error is at least three times its "
                                              "reference's estimated error.")
    big_errs = [num(r["error"]) for r in pa if r["stable"] == "1" and abs(num(r["dt"]) - big_dt) < 1e-12
                and r["integrator"] in ("implicit-euler", "bdf2")]
    small_dt = dts_impl[0] if dts_impl else float("nan")
    small_errs = [num(r["error"]) for r in pa if r["stable"] == "1" and abs(num(r["dt"]) - small_dt) < 1e-12
                  and r["integrator"] in ("implicit-euler", "bdf2")]
    ex_text = ", ".join(f"{num(v):g} s ({sc}, {b})" for (sc, b), v in ex_limits.items())
    it_ex = [int(summary.get(f"newton_study_exact_iterations_step{i}", 0)) for i in (1, 2, 3)]
    it_gn = [int(summary.get(f"newton_study_gn_iterations_step{i}", 0)) for i in (1, 2, 3)]

    log = open(os.path.join(a.data, "log.txt")).read() if os.path.exists(
        os.path.join(a.data, "log.txt")) else ""
    checks = [l.strip() for l in log.splitlines() if l.strip().startswith(("ok:", "FAIL:"))]

    md = TEMPLATE.format(
        mode=a.mode,
        cyl_table=table(["mesh", "bending axis", "springs (unsigned) E/E_c", "slope",
                         "springs (signed) E/E_c", "slope", "dihedral E/E_c", "slope"], cyl_rows),
        fold_table=table(["theta (rad)", "theta (deg)", "exact", "linear springs", "dihedral",
                          "springs rel. error"], fold_rows),
        fold_grid_table=table(["radius r", "fold per hinge h/r (rad)", "E springs", "E dihedral",
                               "springs / dihedral"], fg_rows),
        rf_table=table(["mesh", "n", "hinges", "non-convex", "signed fallbacks",
                        "unsigned max|f| h/k", "signed max|f| h/k", "dihedral max|f| h/k"], rf_rows),
        ca_table=table(["mesh", "model", "nx", "h", "w / w_plate", "w / w_beam"], ca_rows),
        front_table=table(["scenario", "bending", "method", "dt", "run (s)", "max error (m)",
                           "flagged steps"], front_rows),
        all_table=table(["scenario", "bending", "method", "dt", "steps", "ms/step", "run (s)",
                         "max error (m)", "stable", "flagged steps", "Newton it./step",
                         "CG it./solve"], all_rows),
        ref_table=table(["scenario", "bending", "vertices", "reference dt", "run (s)",
                         "estimated error (m)"], ref_rows),
        big_table=table(["scenario", "bending", "implicit-euler/cg20", "implicit-euler/cholmod",
                         "bdf2/cg20", "bdf2/cholmod", "newton/cg20", "newton/cholmod"], big_rows),
        need_table=table(["scenario", "bending", "cheapest run under 1 cm",
                          "cheapest implicit run under 1 cm", "cheapest implicit run under 10 cm"],
                         need_rows),
        order_table=table(["method", "K"] + [f"dt {x:g}" for x in odts] +
                          ["local slopes (successive dt)", "fitted slope"],
                          order_rows),
        newton_table=table(["setting", "dt", "step", "exact Hessian: residuals", "order",
                            "Gauss-Newton: residuals", "order", "exact run ends linearly"],
                           newton_rows),
        front_text="\n".join(front_text), ex_text=ex_text, big_dt=big_dt,
        unresolved_text=unresolved_text, small_dt=small_dt,
        big_lo=min(big_errs, default=float("nan")), big_hi=max(big_errs, default=float("nan")),
        small_lo=min(small_errs, default=float("nan")), small_hi=max(small_errs, default=float("nan")),
        pareto_n=int(summary.get("pareto_n", 0)), pareto_T=summary.get("pareto_T", float("nan")),
        pareto_ref=summary.get("pareto_ref_dt", float("nan")),
        order_n=int(summary.get("order_n", 0)), order_T=summary.get("order_T", float("nan")),
        order_ref=summary.get("order_ref_dt", float("nan")),
        order_ref_err=summary.get("order_ref_error", float("nan")),
        fit_lo=fit_lo, fit_hi=fit_hi,
        s_bdf2=slope.get(("bdf2", "exact"), float("nan")),
        s_bdf2_def=slope.get(("bdf2", "default"), float("nan")),
        s_ie=slope.get(("implicit-euler", "exact"), float("nan")),
        s_ie_def=slope.get(("implicit-euler", "default"), float("nan")),
        ncg_best=ncg_best, npanels=len(panels), rt_springs=rt_springs, rt_dihedral=rt_dihedral, acc10_dihedral=short(acc10_dihedral),
        acc_springs=short(acc_springs), acc_dihedral=short(acc_dihedral),
        acc_dihedral_impl=short(acc_dihedral_impl),
        cg20_min=min(cg20_vs, default=float("nan")), cg20_max=max(cg20_vs, default=float("nan")),
        newton_ie_min=min(newton_vs_ie, default=float("nan")),
        newton_ie_max=max(newton_vs_ie, default=float("nan")),
        bdf2_ie_min=min(bdf2_vs_ie, default=float("nan")),
        bdf2_ie_max=max(bdf2_vs_ie, default=float("nan")),
        newton_cg_flag=100 * min(newton_cg_flag, default=float("nan")),
        nw_nx=int(summary.get("newton_nx", 0)), nw_ny=int(summary.get("newton_ny", 0)),
        nw_angle=summary.get("newton_angle_deg", float("nan")),
        nw_rho=summary.get("newton_density", float("nan")), nw_k=summary.get("newton_k", float("nan")),
        nw_dt=summary.get("newton_dt", float("nan")), nw_big_dt=summary.get("newton_large_dt", float("nan")),
        nw_it_ex=" / ".join(map(str, it_ex)), nw_it_gn=" / ".join(map(str, it_gn)),
        nw_order=summary.get("newton_exact_worst_order", float("nan")),
        nw_big_fell=linear_exact("large-dt"),
        cost_table=table(["solver"] + [f"{v} vertices (ms)" for v in verts] + ["growth exponent"],
                         cost_rows),
        fold1=summary.get("fold_1pct_rad", float("nan")),
        fold1deg=summary.get("fold_1pct_rad", float("nan")) * 180 / math.pi,
        fold10=summary.get("fold_10pct_rad", float("nan")),
        fold10deg=summary.get("fold_10pct_rad", float("nan")) * 180 / math.pi,
        eq_s=summary.get("cylinder_equilateral_springs_ratio", float("nan")),
        eq_d=summary.get("cylinder_equilateral_dihedral_ratio", float("nan")),
        ow_along=summary.get("cylinder_oneway_along_springs", float("nan")),
        ow_across=summary.get("cylinder_oneway_across_springs", float("nan")),
        checks="\n".join(f"- `{c}`" for c in checks) or "- (no log)",
    )
    with open(os.path.join(a.docs, "study.md"), "w") as f:
        f.write(md)


TEMPLATE = """# Accuracy study: bending models, meshes and solvers

This page is generated by `study/run_study.sh --{mode}` (program `study/cutsim_study.cpp`, plots
and this page by `study/report.py`); do not edit it by hand. Regenerate it with

    study/run_study.sh            # --quick: a few minutes on 2 cores
    study/run_study.sh --full     # finer meshes, larger cost series (published figures)

The script builds `cutsim_study` (Release, build tree `build/study`, or `$CUTSIM_STUDY_BUILD`), runs it (CSV files in
`build/study/study-data-{mode}/`), and draws the PNG files of `docs/study/` with Python matplotlib
(Agg backend). matplotlib is the study's only extra dependency: the script installs the Debian
package `python3-matplotlib` with `apt-get` if `import matplotlib` fails. The CTest test
`study.quick_smoke` runs `cutsim_study --smoke` (tiny meshes, a few seconds) and fails if one of
the study's assertions does not hold.

## What a user needs to know

- **Calibration.** Both bending models take the same `bendingStiffness` k. For small folds of a
  flat sheet they are the same model: a hinge folded by theta stores k l theta^2 / (3 (hA + hB)).
  On good meshes the energy density tends to (k/6)(kappa1^2 + kappa2^2 - (2/3) kappa1 kappa2), a
  Kirchhoff plate of rigidity **D = k/3 with an effective Poisson ratio of -1/3**. For cylindrical
  bending (cloth folding) set **k = 3 D**. A sheet rolled onto a cylinder of radius r then stores
  D/2 area / r^2: on the equilateral mesh the finest ratio E/E_continuum is {eq_s:.4f} (springs)
  and {eq_d:.4f} (dihedral), converging at first order in h (the missing half-hinges along the
  border).
- **Mesh dependence.** The answer depends on the mesh and on the bending direction, for both
  models alike (they share the per-hinge calibration). On a mesh whose diagonals all run one way,
  bending about an axis along the diagonals converges to the continuum (ratio {ow_along:.3f}),
  across the diagonals it is **{ow_across:.2f} times too stiff and does not converge**; the
  alternating pattern is 1.5 times too stiff about a diagonal axis. Equilateral (triangular
  lattice) meshes are nearly isotropic and converge at first order. Jittered meshes (interior
  vertices moved by up to 0.25 h) do not converge (the error stays at 2 % to 280 % depending on the
  axis: the irregularity does not average out). There, with SOFA's unsigned area weights, the
  springs' energy is dominated by the few non-convex hinges that the jitter creates (a fraction
  that does not shrink under refinement): they hold energy and push at rest, so the total grows
  like 1/h^2 and the rolled sheet looks many times too stiff (about 8x at h = 1/64, 120x at
  h = 1/128). With signed weights the springs
  give the dihedral model's numbers to 4 digits. Use k = 3 D on equilateral-like meshes; on
  structured right-triangle meshes expect up to 3x anisotropy.
- **Which bending model.** The linear springs (FastTriangularBendingSprings) have a constant
  stiffness matrix (cheap, exactly linear, unconditionally happy implicit solves) and are accurate
  for folds per hinge below about {fold1:.2f} rad ({fold1deg:.0f} deg: 1 % energy error); their
  energy error reaches 10 % at {fold10:.2f} rad ({fold10deg:.0f} deg) and they saturate
  (sin^2(theta/2)) beyond. They cannot hold a curved rest shape (a cylinder patch at rest feels
  forces). The dihedral model (DihedralBending) is exact for any fold up to +-pi, keeps curved rest
  shapes force-free, and is force-free at rest on every flat mesh (cut, non-convex, jittered); its
  stiffness matrix is the Gauss-Newton one (positive semi-definite, rebuilt every step,
  approximate away from the rest angles). Pick the dihedral model for sharp folds, crumpling, curved
  rest shapes or heavily cut meshes; the springs for smooth cloth at large scale.
- **Area weights of the springs.** On flat meshes with non-convex hinges (cuts, strong jitter)
  unsigned (SOFA) weights push the cloth in its own plane at rest; signed weights remove that force
  exactly unless they fall back to unsigned weights (a signed weight beyond 10: nearly degenerate
  hinges, counted in `signedFallbacks`). Use `areaWeights = signed` for cut meshes.
- **Which integrator and solver (sections e-g).** Measured on a hanging and a cut cloth of
  {pareto_n} x {pareto_n} vertices, each bending model, over {pareto_T:g} s:
  - *Explicit* (symplectic) Euler is stable only below a limit that depends on the mesh, the
    stiffness and the bending model: {ex_text}. Where it is stable it is by far the cheapest per
    step and, not damping, the most accurate per second: on these small cloths the cheapest run under
    1 cm of error is {acc_springs} (hanging, springs) and {acc_dihedral} (cut, dihedral). The limit
    scales like h sqrt(mass per area / stretch stiffness) and shrinks on cut meshes (their small
    triangles), finer meshes and stiffer cloth: above it the run blows up (`SolverError`).
  - *Implicit Euler* and *BDF2* (both linearised once per step) are stable at every dt measured but
    damp: their errors are {big_lo:.2g}-{big_hi:.2g} m at dt = {big_dt:g} and still
    {small_lo:.2g}-{small_hi:.2g} m at dt = {small_dt:g}. BDF2's error is
    {bdf2_ie_min:.2f}-{bdf2_ie_max:.2f} times implicit Euler's in the sweep: it is second order only
    with the exact stiffness (section f: slope {s_bdf2:.2f} with the exact K, {s_bdf2_def:.2f} with
    StretchSprings' default stable Jacobian) and only once dt resolves the motion (below about
    2.5e-3 s here), well below the time steps of interactive use.
  - *Newton* (backward Euler solved to convergence, at most 8 iterations to 1e-6) has
    {newton_ie_min:.2f}-{newton_ie_max:.2f} times the error of linearised implicit Euler with
    CHOLMOD at the same dt, for several factorisations per step: one linearisation per step damps
    more than backward Euler solved to convergence (not the stiffness: implicit Euler with the
    exact K in section f is within a few % of the default). With CG capped at
    20 iterations Newton cannot reach its tolerance (at least {newton_cg_flag:.0f} % of its steps are
    flagged) and takes all its iterations, yet at dt = {big_dt:g} it is the most accurate implicit
    run on {ncg_best} of the {npanels} cloths.
  - *CG capped at 20* against *CHOLMOD*, same integrator and dt: the error ratio ranges over
    {cg20_min:.2f}-{cg20_max:.2f}: a capped solve costs accuracy only where it is far from
    converged, and costs much less (CHOLMOD's cost per step does not fall with dt).
  - The Pareto fronts (error against wall time):
{front_text}

## Which configuration to pick for which need

The solver column is read off the measurements of sections e-g (the rest from sections a-d).

| need | bending | area weights | integrator / solver | notes |
|---|---|---|---|---|
| smooth cloth, large meshes, real time (large dt) | FastTriangularBendingSprings, k = 3 D | signed | at dt {big_dt:g} on the hanging cloth: {rt_springs} | stable at any dt; CG's cost is linear in the mesh (section h); expect {big_lo:.1g}-{big_hi:.1g} m of numerical damping after {pareto_T:g} s at dt {big_dt:g} |
| small or soft cloth, accuracy per second | FastTriangularBendingSprings, k = 3 D | signed | explicit-euler just below its limit ({acc_springs} here) | no numerical damping; find the limit by doubling dt (it shrinks on cut and finer meshes) |
| sharp folds, creases, crumpling (folds > ~0.3 rad per hinge) | DihedralBending, k = 3 D | n/a | at dt {big_dt:g} on the cut cloth: {rt_dihedral}; under 10 cm: {acc10_dihedral}; for accuracy explicit below its limit ({acc_dihedral}) | exact energy up to +-pi |
| curved rest shape (garment, shell) | DihedralBending | n/a | implicit (as above) | springs feel forces at rest |
| heavy cutting / tearing | DihedralBending, or springs with signed weights | signed | implicit (as above); explicit only with its limit re-measured on the cut mesh | no spurious rest forces on non-convex hinges; cuts lower the explicit limit |
| large steps on stiff nonlinear folds, converged backward Euler | DihedralBending with exactHessian | n/a | newton + CHOLMOD, exact stiffness | quadratic convergence while M - dt^2 K stays positive definite (section g), else it falls back to the default stiffness |
| quantitative plate bending | either (identical at small deflection), equilateral-like mesh | signed | CHOLMOD (static accuracy) | D = k/3, Poisson -1/3; refine, first-order convergence |
| reference / validation runs | either | signed | bdf2 + CHOLMOD with the exact stiffness (`setExactStiffness(true)`), small dt | second order in dt (slope {s_bdf2:.2f}, section f) |

## a. A flat sheet rolled onto a cylinder

Rest: a flat 1 x 1 sheet; x: the sheet rolled onto a cylinder of radius r = 1 about an axis in the
sheet's plane through its centre. Continuum: E_c = D/2 A / r^2 with D = k/3. Meshes: `oneway`
(every quad split along the same diagonal), `alternating` (the diagonal flips from quad to quad),
`equilateral` (triangular lattice), `jittered` (oneway, interior vertices moved by up to 0.25 h).
Models: the linear springs with unsigned (SOFA) and signed area weights, and the dihedral model, all
at k = 1. The slope is the least-squares slope of log |E/E_c - 1| against log h (1 = first order;
<= 0: no convergence). The CSV file also holds each model's energy at rest (non-zero only for the
unsigned springs on meshes with non-convex hinges).

![cylinder energy error](study/cylinder_error.png)

{cyl_table}

## b. The linear model against the fold angle

Hinge H of bending-springs.md (l = 1, hA = 1, hB = 2, k = 1) folded by theta about its edge. Exact:
k l theta^2 / (3 (hA + hB)) = theta^2 / 9 (what the dihedral model stores). The linear springs store
(4/3) k l sin^2(theta/2) / (hA + hB): relative error ~ theta^2 / 12, 1 % at {fold1:.3f} rad, 10 %
at {fold10:.3f} rad.

![fold error](study/fold_error.png)

{fold_table}

The same on a flat 9 x 9 `oneway` grid (h = 1/8) rolled ever tighter (the fold per hinge is about
h / r):

{fold_grid_table}

## c. Rest forces of flat meshes: unsigned vs signed weights

Flat meshes (10 x 10, k = 1): jittered by up to 0.2 h and 0.45 h, and a 0.2 h jittered mesh cut
along three polylines (`cutPolyline`: splits and snaps make non-convex hinges). Force scale: k / h.
"Non-convex" counts hinges whose unsigned and signed weights differ; "signed fallbacks" those where
the signed weights were refused (a weight beyond 10) and the unsigned ones used.

With jitter 0.45 the finer meshes contain nearly degenerate hinges whose signed weights would
exceed 10: those fall back to the unsigned weights and keep their rest force (the "signed
fallbacks" column), which is why the signed curve rises there. The dihedral model has no weights
and no rest force on any of these meshes.

![rest forces](study/rest_forces.png)

{rf_table}

## d. A cantilever strip under a tip load

A strip L = 1 by b = 0.25 (`nx` x `(nx-1)/4+1` vertices), clamped by fixing the two first columns
of vertices, loaded by a total tip force F = 1e-6 (consistent nodal loads), held in plane by
StretchSprings (stiffness 1e4); the static deflection solves (-K) u = F on the free DOFs with the
assembled K (Eigen's sparse LDL^T). References: plate in cylindrical bending w = F L^3 / (3 D b)
with D = k/3; a narrow beam with Poisson ratio -1/3 is 9/8 of that. Both bending models give the
same numbers: around a flat rest shape their stiffness matrices are identical in the out-of-plane
direction (a hinge has one bending mode). The deflection converges at first order (successive
differences halve with h; the clamp sits between the two fixed columns, an O(h) error in the free
length) to about 1.22 (oneway) and 1.23 (alternating) times the plate value, by Richardson
extrapolation: about 8-9 % softer than a narrow beam of Poisson ratio -1/3 (9/8 of the plate value),
and 22 % softer than the plate formula. A strip of b/L = 0.25 with free long edges is neither a
plate in cylindrical bending nor a narrow beam, and these structured meshes are anisotropic
(section a), so this study does not separate the two effects; what a user can rely on is that the
answer converges, that it is within 10 % of beam theory with the effective Poisson ratio -1/3, and
that the mesh pattern changes it by about 1 %.

![cantilever](study/cantilever.png)

{ca_table}

## e. Error against wall time: bending model x integrator x linear solver x dt

The test cloth: a 1 x 1 m `alternating` grid of {pareto_n} x {pareto_n} vertices (density 0.2 kg/m^2),
StretchSprings (stiffness 1000, default stable Jacobian) and a bending model of k = 1e-3
(FastTriangularBendingSprings with signed weights, or DihedralBending with its default Gauss-Newton
stiffness), the two corners of one edge fixed, gravity 9.81 m/s^2, starting flat and at rest: it
falls and swings about its fixed edge. The *cut* cloth is the same sheet cut before it starts
(`cutPolyline`: a kinked slit across the middle and a notch from the free edge). Integrators:
explicit-euler; implicit-euler, bdf2 and newton (at most 8 iterations to a relative residual of
1e-6, exact stiffness, line search), each with CG (Jacobi, tolerance 1e-8, warm-started) capped at
20 or 100 iterations, or CHOLMOD; `onSolveFailure = warn`, so a capped CG stays capped and its steps
are counted as flagged. Implicit time steps {big_dt:g} down to 8 times smaller; explicit: dt doubled
from 3.125e-5 until the run blows up (a `SolverError` on a non-finite value, or an error above
1 m). The error is the largest distance of a vertex at T = {pareto_T:g} s from a reference of the
same cloth and bending model: **BDF2 + CHOLMOD with the fields' exact stiffness at dt =
{pareto_ref:.3g}** (the smallest implicit dt / 32); its own error is estimated from a second run at
twice its dt (|x(2dt) - x(dt)| / 3, second order) and is at least five times below every error
measured by an implicit run (a check below; on the uncut cloths it is hundreds of times below,
the cut cloths' references converge less well). {unresolved_text} Wall-clock times on a shared 2-core machine (noisy to +-30 %). The Pareto
front of each panel (the runs that no other run beats in both time and error) is circled.

![pareto](study/pareto.png)

The fronts:

{front_table}

Errors and run times at the largest time step, dt = {big_dt:g} (interactive use):

{big_table}

The cheapest runs that reach an accuracy:

{need_table}

The references:

{ref_table}

<details><summary>Every run</summary>

{all_table}

</details>

## f. Order of accuracy

The hanging cloth with the springs ({order_n} x {order_n} vertices, the same builder as in e),
position error at t = {order_T:g} s (while it still swings) against BDF2 + CHOLMOD with the exact
stiffness at dt = {order_ref:.3g} (the smallest dt / 32; estimated error {order_ref_err:.2g} m).
Each integrator runs with CHOLMOD, once with the exact stiffness (StretchSprings without the stable
Jacobian; the springs' K is exact) and once with the default one. Slopes are least-squares fits of
log error against log dt over the three smallest steps, dt = {fit_lo:g} to {fit_hi:g} s (all
errors there are far above the reference's); the largest step does not resolve the cloth's motion
yet (its local slope is about 1 for every method) and is shown but not fitted.

![order](study/order.png)

{order_table}

BDF2 with the exact stiffness has slope {s_bdf2:.2f}, implicit Euler {s_ie:.2f}. With the default
stable Jacobian of StretchSprings (not the derivative of the force on compressed springs) BDF2's
linearisation makes an O(dt^2) error per step where springs are compressed, a first-order term
whose constant is small here: its fitted slope is {s_bdf2_def:.2f} and its local slope lags the
exact one's at the smallest steps (see the table; on the smoke test's coarser, shorter run it is
about 1). Use the exact stiffness (`setExactStiffness(true)` on the model or the field) when BDF2
is meant to be second order.

## g. Newton's convergence on a dihedral fold

A sheet 1 x 0.5 m (`alternating`, {nw_nx} x {nw_ny} vertices, density {nw_rho:g} kg/m^2,
StretchSprings 1000, DihedralBending k = {nw_k:g}) whose half x > 0.5 is folded by
{nw_angle:.0f} deg about a grid line, released at rest (no gravity, nothing fixed). Newton +
CHOLMOD, line search, tolerance 1e-10, three steps of dt = {nw_dt:g}: with the exact stiffness
(DihedralBending's exact Hessian, StretchSprings' exact K) and with the default (Gauss-Newton)
stiffness. At this setting the exact system M - dt^2 K is positive definite at the start and the end
of every step (checked by a Cholesky factorisation), and the exact runs never fall back: the
exact Hessian ends **quadratically** (terminal order at least {nw_order:.2f}; {nw_it_ex}
iterations in the three steps) and Gauss-Newton **linearly** ({nw_it_gn} iterations). The right
panel is the same sheet at dt = {nw_big_dt:g}, where Newton falls back to the default stiffness
for the rest of a step whose exact system is indefinite at an iterate: in {nw_big_fell} of the
three steps the exact run ends linearly, its residuals then following Gauss-Newton's.
A lighter sheet or a larger step loses the quadratic convergence that way; a heavier sheet or a
smaller step keeps it.
"order" is log(e_k+1 / e_k) / log(e_k / e_k-1) at the end of the sequence (the larger of its last
two values).

![newton](study/newton.png)

{newton_table}

## h. Cost of one step against the mesh size

The hanging cloth with the springs, 3 steps after a warm-up step (one step above 90 000 vertices);
explicit at dt = 1e-4, implicit Euler at dt = 5e-3.

![solver cost](study/solver_cost.png)

{cost_table}

## Checks of this run

{checks}
"""

if __name__ == "__main__":
    main()
