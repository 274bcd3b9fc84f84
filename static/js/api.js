// The REST API (app/streaming/PROTOCOL.md "REST"), every route relative to the page ("api/...").
// The browser authenticates with the HttpOnly cookie set by POST api/login.

import { httpUrl } from "./urls.js";

export class ApiError extends Error {
  constructor(status, message) {
    super(message);
    this.status = status;
  }
}

// The server's error body is {"detail": "what went wrong", "reason": "machine_word"}
// (app/api/errors.py); anything else (a proxy's error page) is reported by its status.
export function errorMessage(status, body) {
  const detail = body?.detail;
  return typeof detail === "string" ? detail : `HTTP ${status}`;
}

export class Api {
  constructor({ onUnauthorized } = {}) {
    this.onUnauthorized = onUnauthorized;
  }

  async request(method, path, body) {
    const init = { method, credentials: "same-origin", headers: {} };
    if (body !== undefined) {
      init.headers["Content-Type"] = "application/json";
      init.body = JSON.stringify(body);
    }
    let response;
    try {
      response = await fetch(httpUrl(`api/${path}`), init);
    } catch (err) {
      throw new ApiError(0, `server unreachable (${err.message})`);
    }
    const text = await response.text();
    let data = null;
    if (text) {
      try {
        data = JSON.parse(text);
      } catch {
        data = null; // not JSON (a proxy's error page): report the status alone
      }
    }
    if (!response.ok) {
      if (response.status === 401 && path !== "login") this.onUnauthorized?.();
      throw new ApiError(response.status, `${errorMessage(response.status, data)} (${method} api/${path})`);
    }
    return data;
  }

  login(token) {
    return this.request("POST", "login", { token });
  }
  logout() {
    return this.request("POST", "logout");
  }
  status() {
    return this.request("GET", "status");
  }
  robot() {
    return this.request("GET", "robot");
  }
  // A goal in metres; `yaw` (the heading dragged on the map) is sent when given.
  goal(x, y, yaw = null) {
    return this.request("POST", "goal", yaw === null ? { x, y } : { x, y, yaw });
  }
  cancelGoal() {
    return this.request("DELETE", "goal");
  }
  restartTour() {
    return this.request("POST", "tour");
  }
  setMode(mode, map, newMap = false) {
    return this.request("PUT", "mode", { mode, ...(map ? { map } : {}), ...(newMap ? { new_map: true } : {}) });
  }
  setPose(x, y, yaw) {
    return this.request("POST", "pose", { x, y, yaw });
  }
  teleop(v, w) {
    return this.request("POST", "teleop", { v, w });
  }
  startMapping() {
    return this.request("POST", "mapping/start");
  }
  stopMapping() {
    return this.request("POST", "mapping/stop");
  }
  places() {
    return this.request("GET", "places");
  }
  addPlace(name, x, y, yaw) {
    return this.request("POST", "places", { name, x, y, yaw });
  }
  updatePlace(name, changes) {
    return this.request("PATCH", `places/${encodeURIComponent(name)}`, changes);
  }
  deletePlace(name) {
    return this.request("DELETE", `places/${encodeURIComponent(name)}`);
  }
  goToPlace(name) {
    return this.request("POST", `places/${encodeURIComponent(name)}/go`);
  }
  maps() {
    return this.request("GET", "maps");
  }
  saveMap(name) {
    return this.request("POST", "maps", { name });
  }
  loadMap(name) {
    return this.request("POST", `maps/${encodeURIComponent(name)}/load`);
  }
  deleteMap(name) {
    return this.request("DELETE", `maps/${encodeURIComponent(name)}`);
  }
  sessions() {
    return this.request("GET", "sessions");
  }
  saveSession(name) {
    return this.request("POST", "sessions", { name });
  }
  resumeSession(name) {
    return this.request("POST", `sessions/${encodeURIComponent(name)}/resume`);
  }
  deleteSession(name) {
    return this.request("DELETE", `sessions/${encodeURIComponent(name)}`);
  }
}
