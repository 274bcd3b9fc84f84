// The status bar (connection, mode, localized, worker rate, navigation, last error) and the robot
// details panel, refreshed from the state.

import { degrees } from "./geometry.js";

const MODE_NAMES = { mapping: "Mapping", localization: "Localization", ekf: "EKF SLAM" };

function setPill(el, text, tone) {
  el.textContent = text;
  el.classList.toggle("good", tone === "good");
  el.classList.toggle("warn", tone === "warn");
}

export class StatusBar {
  constructor(state, root = document) {
    this.state = state;
    this.conn = root.getElementById("st-conn");
    this.mode = root.getElementById("st-mode");
    this.loc = root.getElementById("st-loc");
    this.rate = root.getElementById("st-rate");
    this.nav = root.getElementById("st-nav");
    this.replay = root.getElementById("st-replay");
    this.error = root.getElementById("st-error");
    this.details = root.getElementById("details");
    this.banner = root.getElementById("offline-banner");
  }

  render() {
    const { state } = this;
    const s = state.status;
    this.conn.classList.toggle("online", state.online);
    this.conn.classList.toggle("offline", !state.online);
    this.conn.querySelector("span").textContent = state.online ? "online" : "offline";
    this.banner.hidden = state.online;

    const mode = s?.mode;
    this.mode.textContent = mode ? `${MODE_NAMES[mode] ?? mode}${s.mapping === false && mode === "mapping" ? " (paused)" : ""}` : "—";
    const localized = state.pose?.localized ?? s?.localized;
    if (localized === undefined) setPill(this.loc, "—");
    else setPill(this.loc, localized ? "localized" : "not localized", localized ? "good" : "warn");

    const worker = s?.worker;
    if (s?.preparing) {
      // The first start compiles the estimator's kernels (about a minute): say so, with progress.
      const { done, total, stage } = s.preparing;
      setPill(this.rate, `preparing ${done + 1}/${total}`, "warn");
      this.rate.title = `Preparing the estimator (compiled on the first start, then cached): ${stage}`;
    } else if (worker) {
      const alive = worker.alive !== false;
      setPill(this.rate, alive ? `${(worker.rate_hz ?? 0).toFixed(1)} Hz` : "worker down", alive ? "" : "warn");
      this.rate.title = `SLAM worker: ${worker.steps ?? 0} steps, ${worker.restarts ?? 0} restarts`;
    }
    const nav = state.path?.state ?? s?.nav?.state ?? "idle";
    const reason = state.path?.reason ?? s?.nav?.reason;
    // The reason of a failure is in the error pill already: here only the state (and the tour).
    const touring = s?.nav?.touring === true && nav !== "failed";
    setPill(this.nav, touring ? `tour: ${nav}` : nav, nav === "failed" ? "warn" : nav === "arrived" ? "good" : "");
    this.nav.title = touring
      ? "The scripted tour is running; a goal, driving by hand or Cancel ends it."
      : `navigation${reason ? `: ${reason}` : ""}`;

    this.renderReplay(s?.replay);

    const message = state.lastError?.message ?? worker?.last_error ?? null;
    this.error.hidden = !message;
    this.error.textContent = message ? `⚠ ${message}` : "";
    this.error.title = message ? `${message} (click to dismiss)` : "";

    this.renderDetails(s, worker);
  }

  // A log played instead of a robot (homebot serve --replay): which log, how far, which phase.
  renderReplay(replay) {
    this.replay.hidden = !replay;
    if (!replay) return;
    const progress = replay.phase === "playing" ? ` ${replay.played}/${replay.records}` : ` ${replay.phase}`;
    setPill(this.replay, `replay ${replay.log}${progress}`, replay.phase === "finished" ? "good" : "");
  }

  renderDetails(s, worker) {
    const pose = this.state.pose ?? (s?.pose ? { ...s.pose } : null);
    const rows = [
      ["pose", pose ? `x ${pose.x.toFixed(2)} m, y ${pose.y.toFixed(2)} m, ${degrees(pose.yaw).toFixed(0)}°` : "—"],
      ["stream", `${this.state.rate("pose").toFixed(1)} poses/s`],
      ["map", s?.map ? `${s.map.width}×${s.map.height} cells @ ${(s.map.resolution * 100).toFixed(0)} cm` : "—"],
      ["room", s?.room ?? "—"],
      ["path", s?.nav?.state === "driving" && s?.path_length ? `${s.path_length.toFixed(2)} m` : "—"],
      ["worker", worker ? `pid ${worker.pid ?? "—"}, ${worker.steps ?? 0} steps, ${worker.restarts ?? 0} restarts` : "—"],
      ["source", s ? (s.replay ? `replay of ${s.replay.log}` : s.sim ? "simulation" : "robot") : "—"],
      ["loops", s?.loops ? `${s.loops.closures} closed, ${s.loops.edges} edges, ${s.loops.solves} solves` : "—"],
    ];
    this.details.replaceChildren(
      ...rows.flatMap(([k, v]) => {
        const dt = document.createElement("dt");
        dt.textContent = k;
        const dd = document.createElement("dd");
        dd.textContent = v;
        return [dt, dd];
      }),
    );
  }
}
