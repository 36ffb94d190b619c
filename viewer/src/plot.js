// A line plot of steps.csv columns against time on a 2D canvas, with a legend and a cursor at
// the player's current time.
const COLORS = ['#4e9cff', '#ff8a3d', '#49d17d', '#e05a8a', '#c9b23a', '#9b7bff', '#36c9c6', '#d0d4da'];

function niceTicks(lo, hi, count) {
  const span = hi - lo;
  if (!(span > 0)) return [lo];
  const step0 = span / count;
  const mag = 10 ** Math.floor(Math.log10(step0));
  const step = [1, 2, 5, 10].map((m) => m * mag).find((s) => s >= step0) || 10 * mag;
  const ticks = [];
  for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) ticks.push(Math.abs(v) < step * 1e-9 ? 0 : v);
  return ticks;
}

function label(v) {
  if (v === 0) return '0';
  const a = Math.abs(v);
  if (a >= 1e4 || a < 1e-2) return v.toExponential(1);
  return Number(v.toPrecision(3)).toString();
}

export class Plot {
  constructor(canvas, time) {
    this.canvas = canvas;
    this.time = time;
    this.series = [];
    this.cursor = null;
    this.log = false;
  }

  setSeries(series, log = false) {
    this.series = series.filter((s) => s.values);
    this.log = log;
    let lo = Infinity, hi = -Infinity;
    for (const s of this.series) {
      for (const v of s.values) {
        const y = this.y(v);
        if (Number.isFinite(y)) { lo = Math.min(lo, y); hi = Math.max(hi, y); }
      }
    }
    if (!Number.isFinite(lo)) { lo = 0; hi = 1; }
    if (hi - lo < 1e-12 * Math.max(1, Math.abs(hi))) { lo -= 0.5 * Math.max(1e-12, Math.abs(lo)); hi += 0.5 * Math.max(1e-12, Math.abs(hi)); }
    this.yRange = [lo, hi];
    this.draw();
  }

  y(v) { return this.log ? (v > 0 ? Math.log10(v) : NaN) : v; }

  setCursor(t) { this.cursor = t; this.draw(); }

  resize() {
    const r = this.canvas.getBoundingClientRect();
    const ratio = window.devicePixelRatio || 1;
    this.canvas.width = Math.max(1, Math.round(r.width * ratio));
    this.canvas.height = Math.max(1, Math.round(r.height * ratio));
    this.ratio = ratio;
    this.draw();
  }

  frame() {
    const ratio = this.ratio || 1;
    const w = this.canvas.width / ratio, h = this.canvas.height / ratio;
    return { left: 58, right: w - 22, top: 16 + 13 * (this.legendRows || 1), bottom: h - 20, w, h };
  }

  timeAt(px) {
    const f = this.frame();
    if (!this.time || this.time.length === 0 || px < f.left || px > f.right) return null;
    const t0 = this.time[0], t1 = this.time[this.time.length - 1];
    return t0 + ((px - f.left) / (f.right - f.left)) * (t1 - t0);
  }

  draw() {
    const ctx = this.canvas.getContext('2d');
    const ratio = this.ratio || 1;
    ctx.setTransform(ratio, 0, 0, ratio, 0, 0);
    ctx.font = '11px system-ui, sans-serif';
    // Legend, right of the group's menu, in as many rows as it needs.
    const legend = [];
    {
      const w = this.canvas.width / ratio;
      const x0 = Math.min(w * 0.45, 230);
      let lx = x0, row = 0;
      this.series.forEach((s, k) => {
        const text = s.name.replace(/^potential_/, 'V ');
        const tw = ctx.measureText(text).width;
        if (lx + tw + 20 > w && lx > x0) { row++; lx = x0; }
        legend.push({ text, x: lx, y: 12 + 13 * row, color: COLORS[k % COLORS.length] });
        lx += tw + 24;
      });
      this.legendRows = row + 1;
    }
    const f = this.frame();
    ctx.clearRect(0, 0, f.w, f.h);
    if (!this.time || this.time.length < 1 || f.right <= f.left || f.bottom <= f.top) return;
    const t0 = this.time[0], t1 = Math.max(this.time[this.time.length - 1], t0 + 1e-12);
    const [lo, hi] = this.yRange || [0, 1];
    const X = (t) => f.left + ((t - t0) / (t1 - t0)) * (f.right - f.left);
    const Y = (v) => f.bottom - ((v - lo) / (hi - lo)) * (f.bottom - f.top);
    ctx.font = '11px system-ui, sans-serif';
    ctx.strokeStyle = '#30353d';
    ctx.fillStyle = '#8a929c';
    ctx.lineWidth = 1;
    ctx.textAlign = 'right';
    ctx.textBaseline = 'middle';
    for (const v of niceTicks(lo, hi, 4)) {
      ctx.beginPath(); ctx.moveTo(f.left, Y(v)); ctx.lineTo(f.right, Y(v)); ctx.stroke();
      ctx.fillText(this.log ? `1e${Math.round(v)}` : label(v), f.left - 4, Y(v));
    }
    ctx.textAlign = 'center';
    ctx.textBaseline = 'top';
    for (const t of niceTicks(t0, t1, 8)) ctx.fillText(`${label(t)} s`, X(t), f.bottom + 4);
    // The lines, thinned to about one point per pixel column (min and max kept).
    const n = this.time.length;
    const columns = Math.max(1, Math.round(f.right - f.left));
    this.series.forEach((s, k) => {
      ctx.strokeStyle = COLORS[k % COLORS.length];
      ctx.lineWidth = 1.4;
      ctx.beginPath();
      let started = false;
      const per = Math.max(1, Math.floor(n / columns));
      for (let i = 0; i < n; i += per) {
        let a = Infinity, b = -Infinity;
        for (let j = i; j < Math.min(n, i + per); j++) {
          const y = this.y(s.values[j]);
          if (Number.isFinite(y)) { a = Math.min(a, y); b = Math.max(b, y); }
        }
        if (!Number.isFinite(a)) { started = false; continue; }
        const x = X(this.time[i]);
        if (!started) { ctx.moveTo(x, Y(a)); started = true; } else ctx.lineTo(x, Y(a));
        if (b !== a) ctx.lineTo(x, Y(b));
      }
      ctx.stroke();
    });
    ctx.textAlign = 'left';
    ctx.textBaseline = 'middle';
    for (const l of legend) {
      ctx.fillStyle = l.color;
      ctx.fillRect(l.x, l.y - 1, 10, 3);
      ctx.fillStyle = '#c4c9d0';
      ctx.fillText(l.text, l.x + 13, l.y);
    }
    if (this.cursor !== null && this.cursor >= t0 && this.cursor <= t1) {
      ctx.strokeStyle = '#ffffff';
      ctx.setLineDash([3, 3]);
      ctx.beginPath(); ctx.moveTo(X(this.cursor), f.top); ctx.lineTo(X(this.cursor), f.bottom); ctx.stroke();
      ctx.setLineDash([]);
    }
  }
}
