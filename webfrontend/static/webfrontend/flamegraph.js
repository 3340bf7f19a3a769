// Draws the flame graph of a run's profile, or a differential one of two runs, with d3-flame-graph and
// d3-selection (vendor/d3-flame-graph, shipped with the project: no CDN) from the JSON named in data-profile.
(function () {
  "use strict";
  function draw(element) {
    fetch(element.dataset.profile, {credentials: "same-origin"})
      .then(function (response) { if (!response.ok) { throw new Error(response.status); } return response.json(); })
      .then(function (data) {
        var chart = flamegraph()
          // at least 600 px, so that a frame stays readable; a narrower screen scrolls it in its box (.scroll)
          .width(Math.max(600, element.clientWidth))
          .cellHeight(18)
          .minFrameSize(2)
          .sort(true)
          .setDetailsElement(document.getElementById("flamegraph-details"));
        if (element.dataset.differential) {
          chart.computeDelta(true).setColorMapper(flamegraph.colorMapper.differentialColorMapper);
        }
        d3.select(element).datum(data).call(chart);
        element.dataset.drawn = "1";
      })
      .catch(function (error) { element.textContent = "cannot load the profile: " + error.message; });
  }
  document.addEventListener("DOMContentLoaded", function () {
    document.querySelectorAll("[data-profile]").forEach(draw);
  });
})();
