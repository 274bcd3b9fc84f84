// The dashboard's picture of the robot: the newest frame of each kind from the stream plus what the
// REST API returned. Everything that draws or shows reads from here; `changed()` asks for a redraw.

import { MapTiles } from "./maptiles.js";

const GOAL_MATCH_M = 0.01; // the server echoes the goal it was sent
const RATE_WINDOW_MS = 2000;

export class State {
  constructor() {
    this.map = new MapTiles();
    this.pose = null; // {x, y, yaw, localized, t}
    this.particles = []; // [[x, y, yaw], ...]
    this.scan = null; // {pose: [x, y, yaw], points: [[x, y], ...]}
    this.path = { goal: null, path: [], state: "idle", reason: null };
    this.landmarks = { landmarks: [], covariances: [] };
    this.status = null; // GET api/status
    this.robot = null; // GET api/robot: the robot file in use ({footprint_radius, wheels, laser, limits})
    this.places = []; // [{name, x, y, yaw}]
    this.maps = []; // [{name, created, width, height, resolution}]
    this.goalHeading = null; // {x, y, yaw}: the heading the user dragged for the goal at (x, y)
    this.online = false;
    this.lastError = null;
    this.rates = new Map(); // message type -> arrival times (ms) within the last RATE_WINDOW_MS
    this.listeners = new Set();
    this.dirty = true;
  }

  subscribe(listener) {
    this.listeners.add(listener);
    return () => this.listeners.delete(listener);
  }

  changed(what) {
    this.dirty = true;
    for (const listener of this.listeners) listener(what);
  }

  // Note the arrival of a message: the status bar shows the rate at which poses arrive.
  tick(type, now = performance.now()) {
    let times = this.rates.get(type);
    if (!times) {
      times = [];
      this.rates.set(type, times);
    }
    times.push(now);
    while (times.length && times[0] < now - RATE_WINDOW_MS) times.shift();
  }

  // Messages of `type` per second over the last RATE_WINDOW_MS.
  rate(type, now = performance.now()) {
    const times = this.rates.get(type) ?? [];
    return times.filter((t) => t >= now - RATE_WINDOW_MS).length / (RATE_WINDOW_MS / 1000);
  }

  // The dragged heading of the current goal, if the user gave one for it (null otherwise).
  goalYaw() {
    const g = this.path.goal;
    const h = this.goalHeading;
    const same = g && h && Math.abs(g.x - h.x) < GOAL_MATCH_M && Math.abs(g.y - h.y) < GOAL_MATCH_M;
    return same ? h.yaw : null;
  }

  setError(message) {
    this.lastError = message ? { message, at: new Date() } : null;
    this.changed("error");
  }

  // Apply one JSON message of the stream (PROTOCOL.md "JSON messages").
  handle(message) {
    this.tick(message.type);
    switch (message.type) {
      case "pose":
        this.pose = { x: message.x, y: message.y, yaw: message.yaw, localized: message.localized, t: message.t };
        break;
      case "particles":
        this.particles = message.particles ?? [];
        break;
      case "scan":
        this.scan = { pose: message.pose, points: message.points ?? [] };
        break;
      case "path":
        this.path = { goal: message.goal, path: message.path ?? [], state: message.state, reason: message.reason };
        break;
      case "landmarks":
        this.landmarks = { landmarks: message.landmarks ?? [], covariances: message.covariances ?? [] };
        break;
      case "status":
        this.status = message;
        if (message.mode !== "ekf") this.landmarks = { landmarks: [], covariances: [] };
        break;
      case "error":
        this.setError(message.detail);
        return;
      default:
        return; // hello, pong and future types need no drawing
    }
    this.changed(message.type);
  }
}
