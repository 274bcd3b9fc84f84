// The REST API (app/streaming/PROTOCOL.md "REST"), every route relative to the page ("api/...").
// The browser authenticates with the HttpOnly cookie set by POST api/login.

import { httpUrl } from "./urls.js";

export class ApiError extends Error {
  constructor(status, message, body = null) {
    super(message);
    this.status = status;
    this.body = body;
  }

  // True for a validation error that names `field` (FastAPI's [{loc: ["body", field], ...}]).
  concerns(field) {
    const detail = this.body?.detail;
    return Array.isArray(detail) && detail.some((d) => (d.loc ?? []).includes(field));
  }
}

// FastAPI's error body: {"detail": "reason"} or {"detail": [{loc, msg, type}, ...]}.
export function errorMessage(status, body) {
  const detail = body?.detail;
  if (typeof detail === "string") return detail;
  if (detail && typeof detail === "object" && !Array.isArray(detail)) {
    return String(detail.message ?? detail.reason ?? JSON.stringify(detail)); // e.g. the planner's reason
  }
  if (Array.isArray(detail)) {
    const where = (d) => (d.loc ?? []).filter((p) => p !== "body").join(".") || "input";
    return detail.map((d) => `${where(d)}: ${String(d.msg).replace(/^Value error, /, "")}`).join("; ");
  }
  return `HTTP ${status}`;
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
      throw new ApiError(response.status, `${errorMessage(response.status, data)} (${method} api/${path})`, data);
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
  // A goal in metres; `yaw` (the heading dragged on the map) is sent when given. A server whose goals
  // carry no heading rejects the field: the goal is then sent without it and `headingIgnored` is set.
  async goal(x, y, yaw = null) {
    if (yaw === null) return this.request("POST", "goal", { x, y });
    try {
      return await this.request("POST", "goal", { x, y, yaw });
    } catch (err) {
      if (!(err instanceof ApiError && err.status === 422 && err.concerns("yaw"))) throw err;
      const result = await this.request("POST", "goal", { x, y });
      return { ...result, headingIgnored: true };
    }
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
}
