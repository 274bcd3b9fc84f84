// Driving by hand: arrow keys / WASD, or the on-screen pad (press and hold). While a direction is held
// the command is re-sent every REPEAT_MS (the server holds a command for 0.5 s); releasing everything
// sends one stop.

export const LINEAR_SPEED = 0.3; // m/s (server limit 0.5)
export const ANGULAR_SPEED = 1.2; // rad/s (server limit 2.0)
export const REPEAT_MS = 150;

const KEYS = {
  ArrowUp: "forward",
  KeyW: "forward",
  ArrowDown: "back",
  KeyS: "back",
  ArrowLeft: "left",
  KeyA: "left",
  ArrowRight: "right",
  KeyD: "right",
};

// (v, w) for a set of held directions: forward/back drive, left/right turn CCW/CW (REP-103).
export function command(held) {
  const v = (held.has("forward") ? LINEAR_SPEED : 0) - (held.has("back") ? LINEAR_SPEED : 0);
  const w = (held.has("left") ? ANGULAR_SPEED : 0) - (held.has("right") ? ANGULAR_SPEED : 0);
  return [v, w];
}

export class Teleop {
  constructor({ send, pad, onActive }) {
    this.send = send; // (v, w) => void
    this.onActive = onActive;
    this.keys = new Set(); // directions held on the keyboard
    this.buttons = new Set(); // directions held on the pad
    this.timer = null;

    window.addEventListener("keydown", (e) => this.key(e, true));
    window.addEventListener("keyup", (e) => this.key(e, false));
    window.addEventListener("blur", () => this.releaseAll());
    if (pad) this.bindPad(pad);
  }

  held() {
    return new Set([...this.keys, ...this.buttons]);
  }

  key(e, down) {
    const direction = KEYS[e.code];
    if (!direction || e.ctrlKey || e.metaKey || e.altKey) return;
    const target = e.target;
    if (target && (target.isContentEditable || ["INPUT", "TEXTAREA", "SELECT"].includes(target.tagName))) return;
    e.preventDefault();
    if (down) this.keys.add(direction);
    else this.keys.delete(direction);
    this.update();
  }

  bindPad(pad) {
    for (const button of pad.querySelectorAll("[data-drive]")) {
      const direction = button.dataset.drive;
      const press = (e) => {
        e.preventDefault();
        button.setPointerCapture?.(e.pointerId);
        if (direction === "stop") this.releaseAll(true);
        else this.buttons.add(direction);
        button.classList.add("held");
        this.update();
      };
      const release = () => {
        button.classList.remove("held");
        this.buttons.delete(direction);
        this.update();
      };
      button.addEventListener("pointerdown", press);
      button.addEventListener("pointerup", release);
      button.addEventListener("pointercancel", release);
      button.addEventListener("lostpointercapture", release);
    }
  }

  update() {
    const held = this.held();
    if (held.size && !this.timer) {
      this.tick();
      this.timer = setInterval(() => this.tick(), REPEAT_MS);
      this.onActive?.(true);
    } else if (held.size) {
      this.tick();
    } else if (this.timer) {
      clearInterval(this.timer);
      this.timer = null;
      this.send(0, 0);
      this.onActive?.(false);
    }
  }

  tick() {
    const [v, w] = command(this.held());
    this.send(v, w);
  }

  releaseAll(sendStop = false) {
    this.keys.clear();
    this.buttons.clear();
    const wasActive = this.timer !== null;
    this.update();
    if (sendStop && !wasActive) this.send(0, 0);
  }
}
