/* Interactive plots of the dashboard, drawn by uPlot (vendor/uplot, MIT) from the JSON the server sends
 * (webfrontend/plots.py says what a plot holds). Every element with data-plots="URL" gets the plots of
 * that URL: drag to zoom (x and y), double-click to zoom out, values of every series under the cursor in
 * the legend, a click on a legend entry switches its series off and on. Plots follow their box's width,
 * so a phone gets narrow plots instead of a page wider than its screen. */
(function () {
  "use strict";

  function fmt(v) {
    if (v === null || v === undefined || Number.isNaN(v)) return "-";
    var a = Math.abs(v);
    if (a !== 0 && (a >= 1e5 || a < 1e-3)) return v.toExponential(4);
    return String(+v.toPrecision(6));
  }

  /* Tick labels of one axis in one form: all fixed-point with the decimals the tick step needs (0.0002,
   * 0.0010), or, for very large or very small values, all in exponent form with the digits that keep them
   * apart (2.0e-5, 1.2e-4) - never 0.001 beside 8.0000e-4. */
  function ticks(splits, log) {
    // a log axis leaves out some of its splits (null): they get no label
    var blank = function (v) { return v === null || v === undefined || !isFinite(v); };
    var finite = splits.filter(function (v) { return !blank(v); });
    if (finite.length < 2) return splits.map(function (v) { return blank(v) ? "" : fmt(v); });
    var big = Math.max.apply(null, finite.map(Math.abs));
    if (big >= 1e5 || big < 1e-3) {
      for (var d = 0; d <= 6; d++) {
        var labels = splits.map(function (v) { return blank(v) ? "" : v === 0 ? "0" : v.toExponential(d); });
        if (new Set(labels.filter(Boolean)).size === labels.filter(Boolean).length) return labels;
      }
    }
    // a log axis' ticks are not evenly spaced (0.2, 0.3, ... 1, 2): the smallest tick sets the decimals
    var step = log ? Math.min.apply(null, finite.map(Math.abs).filter(function (v) { return v > 0; }))
                   : Math.abs(finite[1] - finite[0]) || Math.abs(finite[0]) || 1;
    var decimals = Math.max(0, Math.min(12, Math.ceil(-Math.log10(step) - 1e-9)));
    return splits.map(function (v) { return blank(v) ? "" : v.toFixed(decimals); });
  }

  /* The tick labels of axis ``i`` of plot ``u``: ``ticks`` on its splits, told whether the scale is a log one. */
  function axisTicks(u, splits, i) {
    var scale = u.scales[u.axes[i].scale];
    return ticks(splits, !!scale && scale.distr === 3);
  }

  /* Room for the y tick labels (px), so that the axis title never overlaps them. */
  function ySize(u, values) {
    if (!values || !values.length) return 50;
    var longest = Math.max.apply(null, values.map(function (v) { return String(v).length; }));
    return Math.max(44, 26 + 8 * longest);  // tick 10 px, gap 5 px, about 8 px a character at 12 px
  }

  function seriesOptions(spec) {
    var opts = [{
      label: spec.xlabel,
      value: function (u, v) { return spec.xticks ? (spec.xticks[v] || "-") : fmt(v); }
    }];
    spec.series.forEach(function (s) {
      opts.push({
        label: s.label,
        stroke: s.color,
        width: s.band_edge ? 0 : (s.width || 1.6),
        dash: s.dash ? [6, 4] : undefined,
        spanGaps: true,
        points: { show: !!s.points, size: 6, fill: s.color },
        // a clipped value (C far below the axis) shows its true value on hover
        value: function (u, v, si, di) {
          if (s.hover && di !== null && di !== undefined) return fmt(s.hover[di]);
          return fmt(v);
        }
      });
    });
    return opts;
  }

  function markersHook(spec) {
    return function (u) {
      if (!spec.markers.length) return;
      var ctx = u.ctx, top = u.bbox.top, height = u.bbox.height;
      ctx.save();
      spec.markers.forEach(function (m) {
        var px = u.valToPos(m.x, "x", true);
        if (px < u.bbox.left || px > u.bbox.left + u.bbox.width) return;
        ctx.strokeStyle = m.color;
        ctx.lineWidth = 1.5 * devicePixelRatio;
        ctx.setLineDash([4 * devicePixelRatio, 3 * devicePixelRatio]);
        ctx.beginPath();
        ctx.moveTo(px, top);
        ctx.lineTo(px, top + height);
        ctx.stroke();
      });
      ctx.restore();
    };
  }

  function xAxis(spec) {
    var axis = { label: spec.xlabel, stroke: "#333", grid: { stroke: "#e4e4e4" },
                 values: axisTicks };
    if (spec.xticks) {
      // a categorical abscissa (commits): ticks only at whole indices, named by their labels
      axis.incrs = [1, 2, 5, 10, 20, 50, 100];
      axis.values = function (u, splits) {
        return splits.map(function (v) { return Number.isInteger(v) ? (spec.xticks[v] || "") : ""; });
      };
      axis.rotate = -20;
    }
    return axis;
  }

  function draw(box, spec) {
    var figure = document.createElement("figure");
    figure.className = "chart";
    var holder = document.createElement("div");
    figure.appendChild(holder);
    if (spec.markers.length) {
      var caption = document.createElement("figcaption");
      caption.className = "markers";
      caption.textContent = "marked: " + spec.markers.map(function (m) { return m.label; }).join("; ");
      figure.appendChild(caption);
    }
    box.appendChild(figure);
    var width = Math.max(240, Math.floor(holder.getBoundingClientRect().width) || 600);
    var opts = {
      title: spec.title,
      width: width,
      height: Math.round(Math.min(360, Math.max(220, width * 0.55))),
      series: seriesOptions(spec),
      bands: spec.bands.map(function (b) { return { series: [b.upper + 1, b.lower + 1], fill: b.fill }; }),
      scales: {
        x: { time: false, distr: spec.xlog ? 3 : 1 },
        y: spec.ylimits ? { distr: spec.ylog ? 3 : 1, range: function () { return spec.ylimits; } }
                        : { distr: spec.ylog ? 3 : 1 }
      },
      // ticks in one form per axis (uPlot's default rounds 1.2e-3 and 1.4e-3 alike), room for them
      axes: [xAxis(spec), { label: spec.ylabel, stroke: "#333", size: ySize, grid: { stroke: "#e4e4e4" },
                            values: axisTicks }],
      cursor: { drag: { x: true, y: true, uni: 30 } },
      legend: { live: true },
      hooks: { draw: [markersHook(spec)] }
    };
    // commit labels are drawn slanted from their tick: room on the right for the last one
    if (spec.xticks) opts.padding = [null, 56, null, null];
    var data = [spec.x].concat(spec.series.map(function (s) { return s.values; }));
    var chart = new uPlot(opts, data, holder);
    // a band is one legend entry: its upper edge, named by the band; the lower edge stays out of the legend
    var rows = chart.root.querySelectorAll(".u-legend .u-series");
    spec.bands.forEach(function (b) {
      if (rows[b.lower + 1]) rows[b.lower + 1].style.display = "none";
      var upper = rows[b.upper + 1];
      if (upper && b.label) {
        var label = upper.querySelector(".u-label");
        if (label) label.textContent = b.label;
      }
    });
    figure.uplot = chart;
    if (window.ResizeObserver) {
      new ResizeObserver(function () {
        var w = Math.max(240, Math.floor(holder.getBoundingClientRect().width));
        if (Math.abs(w - chart.width) > 4) chart.setSize({ width: w, height: Math.round(Math.min(360, Math.max(220, w * 0.55))) });
      }).observe(holder);
    }
    return chart;
  }

  function load(box) {
    box.setAttribute("aria-busy", "true");
    fetch(box.dataset.plots, { headers: { Accept: "application/json" } })
      .then(function (r) { if (!r.ok) throw new Error("HTTP " + r.status); return r.json(); })
      .then(function (data) {
        if (!data.plots.length) {
          box.insertAdjacentHTML("beforeend", '<p class="empty">no data series</p>');
        }
        data.plots.forEach(function (spec) { draw(box, spec); });
        box.dataset.drawn = String(data.plots.length);
      })
      .catch(function (e) {
        var p = document.createElement("p");
        p.className = "failure";
        p.textContent = "plot data not available (" + e.message + ")";
        box.appendChild(p);
        box.dataset.drawn = "error";
      })
      .finally(function () { box.removeAttribute("aria-busy"); });
  }

  function start() {
    document.querySelectorAll("[data-plots]").forEach(load);
  }
  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
  window.dashboardPlots = { draw: draw, fmt: fmt, ticks: ticks };
})();
