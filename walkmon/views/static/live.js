// walkmon live page: polls /api/live (same origin only) and updates the page in place, twice a second.
// window.walkmonHops records when each new hop was first shown (for the browser test's latency figure).
(function () {
  "use strict";
  var root = document.getElementById("live");
  var labels = JSON.parse(root.getAttribute("data-labels"));
  var alertWords = JSON.parse(root.getAttribute("data-alert-words"));
  var api = root.getAttribute("data-api");
  window.walkmonHops = [];
  var lastKey = null;

  function set(id, text) {
    var el = document.getElementById(id);
    if (el.textContent !== text) { el.textContent = text; }
  }
  function num(v, digits) {
    return (v === null || v === undefined) ? "\u2013" : Number(v).toFixed(digits);
  }
  function clock(s) {
    if (s === null || s === undefined) { return "\u2013"; }
    s = Math.max(0, Math.round(s));
    var m = Math.floor(s / 60), r = s % 60;
    return m + ":" + (r < 10 ? "0" : "") + r;
  }
  function show(d) {
    var state = document.getElementById("state");
    if (!d.running) {
      state.className = "state stopped";
      set("state", "No session is running" + (d.last_session ? " (newest: session " + d.last_session + ")" : "") + ".");
      return;
    }
    var hop = d.hop;
    if (d.stale) {
      state.className = "state stale";
      set("state", "Session " + d.session_id + ": no new data for " + Math.round(d.stale_s) + " s.");
    } else {
      state.className = "state";
      set("state", "Session " + d.session_id + " is running.");
    }
    set("session", String(d.session_id));
    set("person", d.person || "\u2013");
    if (hop) {
      set("label", hop.walking ? (labels[hop.label] || hop.label) : (labels.not_walking || "not walking"));
      set("activity", hop.activity);
      set("cadence", hop.walking ? num(hop.cadence_spm, 0) : "\u2013");
      set("pitch", num(hop.pitch, 1));
      set("roll", num(hop.roll, 1));
      set("t", clock(hop.t_s));
      var key = d.session_id + ":" + hop.t_s;
      if (key !== lastKey) {
        lastKey = key;
        window.walkmonHops.push({session: d.session_id, t_s: hop.t_s, shown_ms: Date.now(),
                                 label: hop.label, pitch: hop.pitch, roll: hop.roll});
        if (window.walkmonHops.length > 1000) { window.walkmonHops.shift(); }
      }
    }
    var ul = document.getElementById("alerts");
    var items = d.active_alerts.map(function (a) { return (alertWords[a.kind] || a.kind) + " alert: " + a.message; });
    var text = items.join("\n");
    if (ul.getAttribute("data-text") !== text) {
      ul.setAttribute("data-text", text);
      while (ul.firstChild) { ul.removeChild(ul.firstChild); }
      if (!items.length) {
        var li = document.createElement("li"); li.className = "none"; li.textContent = "none"; ul.appendChild(li);
      }
      items.forEach(function (t) { var li = document.createElement("li"); li.textContent = t; ul.appendChild(li); });
    }
    set("updated", new Date().toLocaleTimeString());
  }
  function poll() {
    fetch(api, {credentials: "same-origin", cache: "no-store"})
      .then(function (r) { if (!r.ok) { throw new Error("HTTP " + r.status); } return r.json(); })
      .then(show)
      .catch(function (e) { set("state", "Cannot reach the walkmon server (" + e.message + ")."); })
      .finally(function () { setTimeout(poll, document.hidden ? 5000 : 500); });
  }
  poll();
})();
