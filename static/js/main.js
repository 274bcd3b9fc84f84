// The dashboard's entry point: log in, open the live stream, draw, and wire the controls.
// Data flows one way: stream -> state -> renderer / status bar; user actions -> REST API or socket.

import { Api } from "./api.js";
import { Connection } from "./connection.js";
import { decodeMapFrame } from "./mapframe.js";
import { Panels } from "./panels.js";
import { SessionsPanel } from "./sessions.js";
import { PointerControl } from "./pointer.js";
import { Renderer } from "./renderer.js";
import { RoomsAndZones } from "./rooms.js";
import { State } from "./state.js";
import { StatusBar } from "./statusbar.js";
import { Teleop } from "./teleop.js";

const TOAST_MS = 3500;
const FIT_MARGIN_PX = 16;
const STATUS_POLL_MS = 5000; // the stream sends status at 1 Hz; this covers a stalled stream
const HINTS = {
  goal: "",
  pan: "Drag to move the map; wheel or pinch to zoom.",
  pose: "Set pose: click where the robot is, drag to show where it faces.",
  place: "Click the map where the new place is (drag to give it a heading).",
  zone: "No-go zone: click its corners on the map, then Finish (Esc cancels).",
  wall: "Virtual wall: click both ends on the map (Esc cancels).",
  split: "Split the room: click two points on the map; the room is cut along that line (Esc cancels).",
};

const $ = (id) => document.getElementById(id);

class Dashboard {
  constructor() {
    this.state = new State();
    this.api = new Api({ onUnauthorized: () => this.showLogin("Your session has expired: sign in again.") });
    this.canvas = $("map");
    this.renderer = new Renderer(this.canvas, this.state);
    this.view = this.renderer.view;
    this.statusBar = new StatusBar(this.state);
    this.tool = "goal";
    this.follow = false;
    this.userMovedView = false;
    this.mapQueue = Promise.resolve();
    this.toastTimer = null;
    this.started = false;

    this.connection = new Connection({
      path: "ws",
      onJson: (message) => this.state.handle(message),
      onBinary: (buffer) => this.queueMapFrame(buffer),
      onState: (online, reason) => this.connectionChanged(online, reason),
    });

    this.panels = new Panels({
      api: this.api,
      state: this.state,
      notify: (message) => this.toast(message),
      fail: (error) => this.fail(error),
      onPickPlace: () => this.setTool("place"),
    });

    this.sessions = new SessionsPanel({
      api: this.api,
      notify: (message) => this.toast(message),
      fail: (error) => this.fail(error),
    });

    this.roomsZones = new RoomsAndZones({
      api: this.api,
      notify: (message) => this.toast(message),
      fail: (error) => this.fail(error),
      redraw: () => this.renderer.invalidate(),
      setTool: (tool) => this.setTool(tool),
    });
    this.renderer.overlays.push(this.roomsZones);

    this.pointer = new PointerControl(this.canvas, this.view, {
      getTool: () => this.tool,
      onPick: (tool, x, y, yaw) => this.pick(tool, x, y, yaw),
      onPreview: (preview) => {
        this.renderer.preview = preview;
        this.renderer.invalidate();
      },
      onViewChange: () => {
        this.userMovedView = true;
        this.renderer.invalidate();
      },
    });

    this.teleop = new Teleop({
      pad: $("teleop"),
      send: (v, w) => {
        if (!this.connection.send({ type: "teleop", v, w })) this.api.teleop(v, w).catch((e) => this.fail(e));
      },
    });

    this.state.subscribe((what) => this.stateChanged(what));
    this.bindControls();
    new ResizeObserver(() => this.renderer.resize()).observe(this.canvas);
    this.renderer.resize();
    const loop = () => {
      this.renderer.frame();
      requestAnimationFrame(loop);
    };
    requestAnimationFrame(loop);
  }

  bindControls() {
    for (const button of document.querySelectorAll("[data-tool]")) {
      button.addEventListener("click", () => this.setTool(button.dataset.tool));
    }
    $("fit").addEventListener("click", () => {
      this.userMovedView = false; // follow the growing map again
      this.fitMap();
    });
    for (const box of document.querySelectorAll("[data-layer]")) {
      box.addEventListener("change", () => this.renderer.showLayer(box.dataset.layer, box.checked));
    }
    $("follow").addEventListener("click", () => {
      this.follow = !this.follow;
      $("follow").setAttribute("aria-pressed", String(this.follow));
      this.centerOnRobot();
    });
    $("cancel-goal").addEventListener("click", async () => {
      try {
        await this.api.cancelGoal();
        this.toast("Goal cancelled");
      } catch (err) {
        this.fail(err);
      }
    });
    $("st-error").addEventListener("click", () => this.state.setError(null)); // dismiss
    $("menu-toggle").addEventListener("click", () => {
      const open = document.body.classList.toggle("menu-open");
      $("menu-toggle").setAttribute("aria-expanded", String(open));
    });
    $("logout").addEventListener("click", async () => {
      await this.api.logout().catch(() => {});
      this.showLogin("Signed out.");
    });
    $("login-form").addEventListener("submit", (e) => {
      e.preventDefault();
      this.login($("token-input").value.trim());
    });
    window.addEventListener("keydown", (e) => {
      if (e.key === "Escape") {
        if (this.roomsZones.draft) this.roomsZones.cancel();
        this.setTool("goal");
        this.pointer.cancelPick();
      }
    });
  }

  // Authentication --------------------------------------------------------------------------------

  async boot() {
    const params = new URLSearchParams(location.search);
    const token = params.get("token");
    if (token) {
      // The link the server prints carries the token: exchange it for the cookie, then drop it from
      // the address bar (and the browser history).
      params.delete("token");
      const query = params.toString();
      history.replaceState(null, "", location.pathname + (query ? `?${query}` : "") + location.hash);
      await this.login(token);
      return;
    }
    try {
      this.state.status = await this.api.status();
      this.start();
    } catch (err) {
      if (err.status === 401) this.showLogin("");
      else this.start(); // server down: show the app offline; the stream reconnects by itself
    }
  }

  async login(token) {
    $("login-error").textContent = "";
    if (!token) {
      $("login-error").textContent = "Enter the token.";
      return;
    }
    $("login-button").disabled = true;
    try {
      await this.api.login(token);
      $("token-input").value = "";
      this.start();
    } catch (err) {
      this.showLogin(err.status === 401 ? "That token is not right." : `Could not sign in: ${err.message}`);
    } finally {
      $("login-button").disabled = false;
    }
  }

  showLogin(message) {
    this.connection.stop();
    this.started = false;
    $("app").hidden = true;
    $("login").hidden = false;
    $("login-error").textContent = message;
    $("token-input").focus();
  }

  start() {
    $("login").hidden = true;
    $("app").hidden = false;
    this.renderer.resize();
    if (this.started) return;
    this.started = true;
    this.state.map.clear();
    this.connection.start();
    this.refreshLists();
    this.roomsZones.start();
    clearInterval(this.pollTimer);
    this.pollTimer = setInterval(() => this.pollStatus(), STATUS_POLL_MS);
    this.stateChanged("status");
  }

  async pollStatus() {
    if (!this.started || this.connection.online) return;
    try {
      this.state.handle({ type: "status", ...(await this.api.status()) });
    } catch {
      // offline: the banner already says so
    }
  }

  refreshLists() {
    this.api.robot().then((robot) => {
      this.state.robot = robot;
      this.state.changed("robot");
    }).catch(() => {}); // offline: asked again on the next connect
    this.panels.refreshPlaces();
    this.panels.refreshMaps();
    this.sessions.refresh();
  }

  // Stream ----------------------------------------------------------------------------------------

  connectionChanged(online, reason) {
    this.state.online = online;
    if (online) {
      this.refreshLists(); // the server sends a full map frame on connect, which replaces the map
    } else if (reason === "unauthorized") {
      this.showLogin("Sign in to see the robot.");
      return;
    }
    this.state.changed("connection");
  }

  // Map frames are decoded in arrival order (decoding a zlib frame is asynchronous).
  queueMapFrame(buffer) {
    this.mapQueue = this.mapQueue
      .then(() => decodeMapFrame(buffer))
      .then((frame) => {
        if (this.state.map.apply(frame)) {
          // The whole known map stays in view as it grows, until the user pans or zooms himself.
          if (!this.userMovedView && !this.follow) this.fitMap();
          this.state.changed("map");
        }
      })
      .catch((err) => this.fail(new Error(`bad map frame: ${err.message}`)));
  }

  stateChanged(what) {
    if (what === "pose" && this.follow) this.centerOnRobot();
    if (["status", "connection", "error", "path", "pose"].includes(what)) this.statusBar.render();
    if (what === "status") this.panels.renderMode();
    if (what === "path" && this.state.path.state === "failed" && this.state.path.reason) {
      this.state.lastError = { message: this.state.path.reason, at: new Date() };
    }
  }

  // Map interaction -------------------------------------------------------------------------------

  setTool(tool) {
    this.tool = tool;
    for (const button of document.querySelectorAll("[data-tool]")) {
      button.classList.toggle("active", button.dataset.tool === tool);
    }
    $("map-pane").classList.toggle("tool-pan", tool === "pan");
    $("hint").textContent = HINTS[tool] ?? "";
    if (tool === "place") document.body.classList.remove("menu-open");
  }

  async pick(tool, x, y, yaw) {
    try {
      if (tool === "goal") {
        await this.api.goal(x, y, yaw);
        this.state.goalHeading = yaw === null ? null : { x, y, yaw };
        this.toast(`Goal (${x.toFixed(2)}, ${y.toFixed(2)})`);
      } else if (tool === "pose") {
        const heading = yaw ?? this.state.pose?.yaw ?? 0;
        await this.api.setPose(x, y, heading);
        this.toast("Pose set: localization restarts around it");
        this.setTool("goal");
      } else if (tool === "zone" || tool === "wall" || tool === "split") {
        this.roomsZones.addPoint(x, y);
      } else if (tool === "place") {
        const name = this.panels.placeNameOrComplain();
        if (name) await this.panels.addPlace(name, x, y, yaw ?? 0);
        this.setTool("goal");
      }
    } catch (err) {
      this.fail(err);
    }
    this.state.changed("pick");
  }

  fitMap() {
    const bounds = this.state.map.knownBounds();
    const toolbar = $("tools").getBoundingClientRect();
    const canvasTop = this.canvas.getBoundingClientRect().top;
    if (bounds) this.view.fit(...bounds, FIT_MARGIN_PX, toolbar.bottom - canvasTop);
    else if (this.state.pose) this.view.centerOn(this.state.pose.x, this.state.pose.y);
    this.renderer.invalidate();
  }

  centerOnRobot() {
    const pose = this.state.pose;
    if (!pose) return;
    this.view.centerOn(pose.x, pose.y);
    this.renderer.invalidate();
  }

  // Messages --------------------------------------------------------------------------------------

  toast(message, bad = false) {
    const toast = $("toast");
    toast.textContent = message;
    toast.classList.toggle("bad", bad);
    toast.hidden = false;
    clearTimeout(this.toastTimer);
    this.toastTimer = setTimeout(() => (toast.hidden = true), TOAST_MS);
  }

  fail(error) {
    const message = error?.message ?? String(error);
    this.state.setError(message);
    this.toast(message, true);
  }
}

const dashboard = new Dashboard();
window.homebot = dashboard; // for the browser tests and for poking around in the console
dashboard.boot();
