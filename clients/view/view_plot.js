// coopdyn view: the plot of the selected wrench, beside the 3D view. view_page.html has it inlined
// (clients/view/view.cc puts this file at its PLOT_JS mark) and makes one with ViewPlot(V, at).
//
// Its six components as the source gives them ([moment; force] in its report frame), moments above
// (N*m) and forces below (N), over the run, a white cursor at the frame shown; about each curve its
// +-sigma band and friction bound when the frames carry them. The curves are drawn once into `base`
// (again after dirty(): the wrench, the frames, the size or the bands changed); each draw() copies
// it and draws the cursor. probe() says what is drawn, for the page's #probe.
//
// V: the page's data (V.t, V.wrenches, V.wrench_F, V.wrench_sigma, V.wrench_bound: per frame, 6 per
// drawn wrench, [] without); at: what the page tells it: canvas (the plot's <canvas>), title (the
// element above it), plotdata (an element to hold the plotted series, or null), wrench() (the index
// of the selected wrench, -1 for none), frame() (the frame shown), bands() (the bands are shown).
function ViewPlot(V, at) {
  'use strict';
  var base = document.createElement('canvas'), dirty = true, axes = [], shown = null, K = -1, cursorX = null;
  var COMP = ['mx', 'my', 'mz', 'fx', 'fy', 'fz'], TRACE = ['#e06666', '#66cc66', '#6699ff'];
  function niceTicks(lo, hi, n) {
    var step = ViewPlot.niceCeil((hi - lo) / n), out = [];
    for (var v = Math.ceil(lo / step) * step; v <= hi + 1e-9 * step; v += step) out.push(Math.abs(v) < 1e-12 * step ? 0 : v);
    return out;
  }
  function tNum(x) { return +x.toPrecision(4) + ''; }
  // component c of wrench k at frame i; NaN in an error frame (its numbers are no values: a gap)
  function val(i, k, c) { return V.status[i] === 'error' ? NaN : V.wrench_F[i][6 * k + c]; }
  // the plot's bands (the bar's +-sigma checkbox, #bands=0): about each component's curve, the
  // +-sigma band of the frames that carry a sigma (a translucent fill in the trace's colour) and the
  // friction bound of those that carry one (dashed lines in the trace's colour), in the component's
  // unit (N*m, N): value -+ sigma, value -+ bound, as the source gives them
  function bandHalf(i, k, c, key) {  // the half-width of component c of wrench k at frame i; NaN without
    var s = V[key][i];
    return s.length ? Math.abs(s[6 * k + c]) : NaN;
  }
  // the runs of consecutive frames with a band, as drawn: per frame, or per pixel column (its lowest
  // lo and highest hi) when there are more than two frames a column; each point keeps its frames
  function bandRuns(k, c, key, X, dec) {
    var N = V.t.length;
    var runs = [], run = null;
    for (var i = 0; i < N; ++i) {
      var v = val(i, k, c), d = bandHalf(i, k, c, key);
      if (!isFinite(d) || !isFinite(v)) { run = null; continue; }
      var x = X(V.t[i]), col = Math.floor(x), p = run && run[run.length - 1];
      if (dec && p && p.col === col) { p.lo = Math.min(p.lo, v - d); p.hi = Math.max(p.hi, v + d); p.i1 = i; continue; }
      if (!run) runs.push(run = []);
      run.push({ x: dec ? col + 0.5 : x, col: col, lo: v - d, hi: v + d, i0: i, i1: i });
    }
    return runs;
  }
  function pathAlong(g, run, Yv, key, rev) {  // a run's lo or hi edge (a lone point: 2 px wide)
    var pts = run.length > 1 ? run : [{ x: run[0].x - 1, lo: run[0].lo, hi: run[0].hi }, { x: run[0].x + 1, lo: run[0].lo, hi: run[0].hi }];
    for (var n = 0; n < pts.length; ++n) {
      var p = pts[rev ? pts.length - 1 - n : n];
      if (n || rev) g.lineTo(p.x, Yv(p[key])); else g.moveTo(p.x, Yv(p[key]));
    }
  }
  function drawBands(g, ax, k, p, dec, drawn) {  // drawn[c]: the runs of component c
    for (var j = 0; j < 3; ++j) {
      var c = 3 * p + j, sg = bandRuns(k, c, 'wrench_sigma', ax.X, dec), bd = bandRuns(k, c, 'wrench_bound', ax.X, dec);
      g.fillStyle = TRACE[j]; g.globalAlpha = 0.25;
      sg.forEach(function (r) { g.beginPath(); pathAlong(g, r, ax.Yv, 'hi', false); pathAlong(g, r, ax.Yv, 'lo', true); g.closePath(); g.fill(); });
      g.globalAlpha = 1; g.strokeStyle = TRACE[j]; g.lineWidth = 1; g.setLineDash([4, 3]);
      bd.forEach(function (r) { ['lo', 'hi'].forEach(function (e) { g.beginPath(); pathAlong(g, r, ax.Yv, e, false); g.stroke(); }); });
      g.setLineDash([]);
      drawn[c] = { sigma: sg, bound: bd };
    }
  }
  // what the plot draws of the bands at the cursor's frame, per component: the value, and the lo
  // and hi of the band and of the bound (data units, and page CSS pixels: y of each edge); null when
  // the bands are off or none is drawn there
  function bandProbe(pr) {
    if (!shown) return null;
    var frame = at.frame();
    var pointAt = function (runs) {  // the drawn point that holds the frame
      for (var r = 0; r < runs.length; ++r) for (var n = 0; n < runs[r].length; ++n)
        if (runs[r][n].i0 <= frame && frame <= runs[r][n].i1) return runs[r][n];
      return null;
    };
    var out = COMP.map(function (name, c) {
      var ax = axes[c < 3 ? 0 : 1], s = pointAt(shown[c].sigma), b = pointAt(shown[c].bound);
      var edge = function (p) { return p && { lo: p.lo, hi: p.hi, y_lo: pr.top + ax.Yv(p.lo), y_hi: pr.top + ax.Yv(p.hi), frames: [p.i0, p.i1] }; };
      return { c: name, value: V.wrench_F[frame][6 * K + c], y: pr.top + ax.Yv(V.wrench_F[frame][6 * K + c]), sigma: edge(s), bound: edge(b) };
    });
    return out.some(function (e) { return e.sigma || e.bound; }) ? out : null;
  }
  // the y range of axes p of wrench k: its curves and their bands (shown or not: the checkbox does
  // not move the curves)
  function axisRange(k, p) {
    var N = V.t.length;
    var lo = 0, hi = 0;
    for (var i = 0; i < N; ++i) for (var c = 3 * p; c < 3 * p + 3; ++c) {
      var v = val(i, k, c), s = V.wrench_sigma[i], b = V.wrench_bound[i];
      if (!isFinite(v)) continue;
      var d = Math.max(s.length ? Math.abs(s[6 * k + c]) : 0, b.length ? Math.abs(b[6 * k + c]) : 0);
      if (!isFinite(d)) d = 0;  // (not drawn either)
      if (v - d < lo) lo = v - d;
      if (v + d > hi) hi = v + d;
    }
    if (hi - lo < 1e-9 * Math.max(1, Math.abs(hi))) { lo -= 1; hi += 1; }
    var pad = 0.06 * (hi - lo);
    return [lo - pad, hi + pad];
  }
  function drawAxisFrame(g, ax, p) {  // the box, the value grid and its labels, the components' names
    g.strokeStyle = '#555'; g.lineWidth = 1;
    g.strokeRect(ax.left + 0.5, ax.top + 0.5, ax.width - 1, ax.height - 1);
    g.font = '10px sans-serif'; g.fillStyle = '#aab'; g.textAlign = 'right'; g.textBaseline = 'middle';
    niceTicks(ax.lo, ax.hi, 4).forEach(function (v) {
      var y = Math.round(ax.Yv(v)) + 0.5;
      g.strokeStyle = v === 0 ? '#666' : '#2e343b';
      g.beginPath(); g.moveTo(ax.left + 1, y); g.lineTo(ax.left + ax.width - 1, y); g.stroke();
      g.fillText(tNum(v), ax.left - 4, y);
    });
    g.textAlign = 'left'; g.textBaseline = 'alphabetic';
    g.fillStyle = '#ccd';
    g.fillText(ax.unit, 4, ax.top - 4);
    for (var j = 0; j < 3; ++j) {
      g.fillStyle = TRACE[j];
      g.fillText(COMP[3 * p + j], ax.left + 8 + 30 * j, ax.top - 4);
    }
    g.fillStyle = '#aab';
    var any = function (key) { return V[key].some(function (x) { return x.length > 0; }); }, sg = any('wrench_sigma'), bd = any('wrench_bound');
    if (p === 0 && at.bands() && (sg || bd))
      g.fillText([sg ? '\u00b1\u03c3 shaded' : '', bd ? 'bound dashed' : ''].filter(Boolean).join(', '), ax.left + 98, ax.top - 4);
  }
  // each component's curve: every frame, or per pixel column (more than two frames a column) its
  // first, lowest and highest value; an error frame (or a value that is not finite) breaks it
  function drawTraces(g, ax, k, p) {
    var N = V.t.length;
    var dec = N > 2 * ax.width;
    g.lineWidth = 1.25;
    for (var j = 0; j < 3; ++j) {
      g.strokeStyle = TRACE[j];
      g.beginPath();
      var col = null, cmin = 0, cmax = 0, pen = false;
      var flush = function () {
        if (col !== null && dec) { g.lineTo(col + 0.5, ax.Yv(cmin)); g.lineTo(col + 0.5, ax.Yv(cmax)); }
      };
      for (var i = 0; i < N; ++i) {
        var x = ax.X(V.t[i]), v = val(i, k, 3 * p + j), c = Math.floor(x);
        if (!isFinite(v)) { if (pen) flush(); pen = false; col = null; continue; }
        if (!pen || !dec || c !== col) {
          if (pen) flush();
          if (pen) g.lineTo(x, ax.Yv(v)); else g.moveTo(x, ax.Yv(v));
          pen = true; col = c; cmin = cmax = v;
        } else { cmin = Math.min(cmin, v); cmax = Math.max(cmax, v); }
      }
      if (pen) flush();
      g.stroke();
    }
  }
  function drawPlotBase() {
    var N = V.t.length;
    dirty = false;
    var k = at.wrench();
    var dpr = window.devicePixelRatio || 1, W = at.canvas.width / dpr, H = at.canvas.height / dpr;
    base.width = at.canvas.width; base.height = at.canvas.height;
    var g = base.getContext('2d');
    g.setTransform(dpr, 0, 0, dpr, 0, 0);
    g.fillStyle = '#171a1e'; g.fillRect(0, 0, W, H);
    axes = []; shown = null; K = k;
    if (k < 0 || !(W > 60 && H > 60)) return;
    var t0 = V.t[0], t1 = V.t[N - 1] > t0 ? V.t[N - 1] : t0 + 1;
    var L = 58, R = 10, gap = 26, top = 16, bottom = 20, ah = (H - top - bottom - gap) / 2, drawn = [];
    [0, 1].forEach(function (p) {
      var ax = { left: L, top: top + p * (ah + gap), width: W - L - R, height: ah, unit: p ? 'N' : 'N\u00b7m', t0: t0, t1: t1 };
      var r = axisRange(k, p);
      ax.lo = r[0]; ax.hi = r[1];
      ax.X = function (t) { return ax.left + (t - t0) / (t1 - t0) * ax.width; };
      ax.Yv = function (v) { return ax.top + (ax.hi - v) / (ax.hi - ax.lo) * ax.height; };
      axes.push(ax);
      drawAxisFrame(g, ax, p);
      g.save();
      g.beginPath(); g.rect(ax.left + 1, ax.top + 1, ax.width - 2, ax.height - 2); g.clip();
      if (at.bands()) drawBands(g, ax, k, p, N > 2 * ax.width, drawn);
      drawTraces(g, ax, k, p);
      g.restore();
      if (p === 1) {  // time ticks under the force axes
        g.fillStyle = '#aab'; g.textAlign = 'center'; g.textBaseline = 'top';
        niceTicks(t0, t1, 4).forEach(function (t) { g.fillText(tNum(t), ax.X(t), ax.top + ax.height + 3); });
        g.textAlign = 'left';
        g.fillText('t (s)', 4, ax.top + ax.height + 3);
      }
    });
    if (at.bands()) shown = drawn;
    if (at.plotdata) {
      // per component its value per frame; null in an error frame (a gap)
      var series = COMP.map(function (c, j) {
        return V.t.map(function (t, i) { var v = val(i, k, j); return isFinite(v) ? v : null; });
      });
      at.plotdata.textContent = JSON.stringify({ wrench: V.wrenches[k].name, t: V.t, components: COMP, values: series });
    }
  }
  function draw() {
    var frame = at.frame();
    cursorX = null;
    if (at.wrench() < 0 || !axes) return;
    if (dirty) drawPlotBase();
    var g = at.canvas.getContext('2d'), dpr = window.devicePixelRatio || 1;
    g.setTransform(1, 0, 0, 1, 0, 0);
    g.drawImage(base, 0, 0);
    if (!axes.length) return;
    g.setTransform(dpr, 0, 0, dpr, 0, 0);
    var ax = axes[0];
    cursorX = ax.left + (V.t[frame] - ax.t0) / (ax.t1 - ax.t0) * ax.width;
    var x = Math.round(cursorX) + 0.5;
    g.strokeStyle = '#ffffff'; g.lineWidth = 1;
    g.beginPath();
    axes.forEach(function (a) { g.moveTo(x, a.top + 1); g.lineTo(x, a.top + a.height - 1); });
    g.stroke();
    var k = at.wrench();
    var f = function (j) { var v = val(frame, k, j); return isFinite(v) ? (+v.toPrecision(4)) + '' : '-'; };
    at.title.innerHTML = '';
    at.title.appendChild(document.createTextNode(V.wrenches[k].name + ' in ' + V.wrenches[k].frame + ' (by ' + V.wrenches[k].by + ')'));
    at.title.appendChild(document.createElement('br'));
    at.title.appendChild(document.createTextNode('m (' + [0, 1, 2].map(f) + ') N\u00b7m, f (' + [3, 4, 5].map(f) + ') N'));
  }
  // what the plot shows, in page CSS pixels (pr: the canvas's client rectangle); null without a plot
  function probe(pr) {
    if (at.wrench() < 0 || !axes.length) return null;
    var N = V.t.length;
    return {
      wrench: V.wrenches[K].name, n: N, t0: axes[0].t0, t1: axes[0].t1, cursor_t: V.t[at.frame()], cursor_x: pr.left + cursorX,
      axes: axes.map(function (a) { return { left: pr.left + a.left, top: pr.top + a.top, width: a.width, height: a.height, unit: a.unit, lo: a.lo, hi: a.hi }; }),
      bands: bandProbe(pr)
    };
  }
  return { dirty: function () { dirty = true; }, draw: draw, probe: probe };
}
// the smallest 1, 2 or 5 x 10^k at least x (1 for nothing positive)
ViewPlot.niceCeil = function (x) {
  if (!(x > 0) || !isFinite(x)) return 1;
  var e = Math.pow(10, Math.floor(Math.log10(x)));
  for (var m of [1, 2, 5, 10]) if (m * e >= x * (1 - 1e-12)) return m * e;
  return 10 * e;
};
