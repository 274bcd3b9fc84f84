// The live stream: one websocket that reconnects by itself (exponential back-off) after the server
// restarts or the network drops, and reports whether it is online. JSON text frames and binary frames
// are handed to separate callbacks.

import { wsUrl } from "./urls.js";

export const RECONNECT_MIN_MS = 500;
export const RECONNECT_MAX_MS = 5000;
export const SILENCE_TIMEOUT_MS = 6000; // no frame for this long: the link is dead, reconnect
export const UNAUTHORIZED_CLOSE = 4401; // PROTOCOL.md: missing or wrong token

export class Connection {
  constructor({ path = "ws", onJson, onBinary, onState }) {
    this.path = path;
    this.onJson = onJson;
    this.onBinary = onBinary;
    this.onState = onState;
    this.socket = null;
    this.online = false;
    this.delay = RECONNECT_MIN_MS;
    this.retryTimer = null;
    this.watchdog = null;
    this.stopped = true;
    this.lastFrame = 0;
  }

  start() {
    this.stopped = false;
    this._open();
  }

  stop() {
    this.stopped = true;
    clearTimeout(this.retryTimer);
    clearInterval(this.watchdog);
    if (this.socket) this.socket.close();
    this._setOnline(false, "stopped");
  }

  send(message) {
    if (this.socket && this.socket.readyState === WebSocket.OPEN) {
      this.socket.send(JSON.stringify(message));
      return true;
    }
    return false;
  }

  _open() {
    clearTimeout(this.retryTimer);
    let socket;
    try {
      socket = new WebSocket(wsUrl(this.path)); // authenticated by the login cookie
    } catch (err) {
      this._setOnline(false, String(err));
      this._scheduleRetry();
      return;
    }
    socket.binaryType = "arraybuffer";
    this.socket = socket;
    socket.onopen = () => {
      this.delay = RECONNECT_MIN_MS;
      this.lastFrame = performance.now();
      this._setOnline(true, "");
      clearInterval(this.watchdog);
      this.watchdog = setInterval(() => {
        if (performance.now() - this.lastFrame > SILENCE_TIMEOUT_MS) socket.close();
      }, 1000);
    };
    socket.onmessage = (event) => {
      this.lastFrame = performance.now();
      if (typeof event.data === "string") {
        let message;
        try {
          message = JSON.parse(event.data);
        } catch {
          return; // a malformed frame is dropped; the next one replaces it
        }
        this.onJson?.(message);
      } else {
        this.onBinary?.(event.data);
      }
    };
    socket.onclose = (event) => {
      clearInterval(this.watchdog);
      if (this.socket !== socket) return;
      this.socket = null;
      const reason = event.code === UNAUTHORIZED_CLOSE ? "unauthorized" : `closed (${event.code})`;
      this._setOnline(false, reason);
      if (!this.stopped) this._scheduleRetry();
    };
    socket.onerror = () => {}; // onclose follows and handles it
  }

  _scheduleRetry() {
    clearTimeout(this.retryTimer);
    this.retryTimer = setTimeout(() => this._open(), this.delay);
    this.delay = Math.min(RECONNECT_MAX_MS, this.delay * 2);
  }

  _setOnline(online, reason) {
    const changed = online !== this.online;
    this.online = online;
    if (changed || !online) this.onState?.(online, reason);
  }
}
