// Rooms and no-go zones, on the map and in the sidebar: each room in its colour with its name
// (api/rooms/overlay), the room list with "Go", "Rename", "Merge into" and "Split" (click two points
// on the map: the line the room is cut along), and the editor for no-go zones (click the corners,
// then Finish) and virtual walls (click both ends). Everything goes through the REST API.

const REFRESH_MS = 5000;
export const ZONE_FILL = "rgba(220, 38, 38, 0.28)";
export const ZONE_EDGE = "#dc2626";

function el(tag, props = {}, ...children) {
  const node = document.createElement(tag);
  Object.assign(node, props);
  node.append(...children);
  return node;
}

export class RoomsAndZones {
  constructor({ api, notify, fail, redraw, setTool, root = document }) {
    this.api = api;
    this.notify = notify;
    this.fail = fail;
    this.redraw = redraw; // () => void
    this.setTool = setTool; // (tool) => void
    this.overlay = null;
    this.image = null;
    this.zones = [];
    this.draft = null; // {kind: "zone" | "wall" | "split", points: [[x, y], ...], room?: id}
    this.renaming = null; // the id of the room whose name is being edited (the list then waits)
    this.roomsList = root.getElementById("rooms");
    this.zonesList = root.getElementById("zones");
    this.finishButton = root.getElementById("zone-finish");
    root.getElementById("zone-draw").addEventListener("click", () => this.begin("zone"));
    root.getElementById("wall-draw").addEventListener("click", () => this.begin("wall"));
    this.finishButton.addEventListener("click", () => this.finish());
    root.getElementById("zone-cancel").addEventListener("click", () => this.cancel());
  }

  start() {
    this.refresh();
    clearInterval(this.timer);
    this.timer = setInterval(() => this.refresh(), REFRESH_MS);
  }

  async refresh() {
    try {
      const [overlay, zones] = await Promise.all([this.api.request("GET", "rooms/overlay"), this.api.request("GET", "zones")]);
      this.zones = zones;
      if (overlay.image !== this.overlay?.image) {
        const image = new Image();
        image.onload = () => {
          this.image = image;
          this.redraw();
        };
        if (overlay.image) image.src = overlay.image;
        else this.image = null;
      }
      this.overlay = overlay;
      if (this.renaming === null) this.renderLists();
      this.redraw();
    } catch {
      // offline or signed out: the status bar says so; try again at the next refresh
    }
  }

  renderLists() {
    this.roomsList.replaceChildren(
      ...this.overlay.rooms.map((room) => {
        const swatch = el("i", { className: "swatch", title: room.colour });
        swatch.style.background = room.colour;
        const go = el("button", { type: "button", textContent: "Go", title: `Drive to ${room.name}` });
        go.addEventListener("click", () => this.goTo(room));
        const rename = el("button", { type: "button", textContent: "Rename" });
        const split = el("button", { type: "button", textContent: "Split", title: "Then click two points on the map" });
        const merge = el("select", { ariaLabel: `Merge ${room.name} into`, title: "Merge into another room" },
          el("option", { value: "", textContent: "Merge into…" }),
          ...this.overlay.rooms.filter((r) => r.id !== room.id).map((r) => el("option", { value: r.id, textContent: r.name })));
        const li = el("li", {}, swatch, el("span", { className: "name", textContent: room.name }), go, rename, split, merge);
        rename.addEventListener("click", () => this.editName(li, room));
        split.addEventListener("click", () => this.begin("split", room.id));
        merge.addEventListener("change", () => merge.value && this.merge(Number(merge.value), room));
        li.dataset.room = room.id;
        return li;
      }),
    );
    this.zonesList.replaceChildren(
      ...this.zones.map((zone) => {
        const remove = el("button", { type: "button", textContent: "Delete", className: "danger" });
        remove.addEventListener("click", () => this.remove(zone));
        const what = zone.kind === "wall" ? "virtual wall" : `no-go zone (${zone.points.length} corners)`;
        const li = el("li", {}, el("span", { className: "name", textContent: `${zone.id}: ${what}` }), remove);
        li.dataset.zone = zone.id;
        return li;
      }),
    );
  }

  editName(li, room) {
    this.renaming = room.id;
    const input = el("input", { value: room.name, maxLength: 64, ariaLabel: "New room name" });
    const save = el("button", { type: "submit", textContent: "Save", className: "primary" });
    const cancel = el("button", { type: "button", textContent: "Cancel" });
    const form = el("form", { className: "row rename" }, input, save, cancel);
    form.addEventListener("submit", async (e) => {
      e.preventDefault();
      const name = input.value.trim();
      try {
        if (name && name !== room.name) {
          await this.api.request("PATCH", `rooms/${room.id}`, { name });
          this.notify(`Room renamed to "${name}"`);
        }
      } catch (err) {
        this.fail(err);
      }
      this.renaming = null;
      await this.refresh();
    });
    cancel.addEventListener("click", () => {
      this.renaming = null;
      this.renderLists();
    });
    li.replaceChildren(form);
    input.focus();
    input.select();
  }

  async merge(keep, room) {
    try {
      await this.api.request("POST", "rooms/merge", { keep, absorb: room.id });
      this.notify(`${room.name} merged`);
    } catch (err) {
      this.fail(err);
    }
    await this.refresh();
  }

  async goTo(room) {
    try {
      await this.api.request("POST", `rooms/${room.id}/go`);
      this.notify(`Going to ${room.name}`);
    } catch (err) {
      this.fail(err);
    }
  }

  async remove(zone) {
    try {
      await this.api.request("DELETE", `zones/${zone.id}`);
      await this.refresh();
    } catch (err) {
      this.fail(err);
    }
  }

  begin(kind, room = null) {
    this.draft = { kind, points: [], room };
    this.finishButton.hidden = kind !== "zone";
    this.setTool(kind);
    this.redraw();
  }

  // A click on the map while drawing: a corner of the zone, or an end of the wall.
  addPoint(x, y) {
    if (!this.draft) return;
    this.draft.points.push([x, y]);
    if (this.draft.kind !== "zone" && this.draft.points.length === 2) this.finish();
    this.redraw();
  }

  async finish() {
    const draft = this.draft;
    if (!draft) return;
    this.cancel();
    try {
      if (draft.kind === "split") {
        const [a, b] = draft.points;
        await this.api.request("POST", `rooms/${draft.room}/split`, { a, b });
        this.notify("Room split");
      } else {
        await this.api.request("POST", "zones", { kind: draft.kind, points: draft.points });
        this.notify(draft.kind === "wall" ? "Virtual wall added" : "No-go zone added");
      }
      await this.refresh();
    } catch (err) {
      this.fail(err);
    }
  }

  cancel() {
    this.draft = null;
    this.finishButton.hidden = true;
    this.setTool("goal");
    this.redraw();
  }

  // In world coordinates (the map's transform): the rooms' colours.
  drawWorld(ctx) {
    const o = this.overlay;
    if (!this.image || !o || !o.width) return;
    ctx.save();
    ctx.imageSmoothingEnabled = false;
    const r = o.resolution;
    ctx.drawImage(this.image, 0, 0, o.width, o.height, o.origin[0], o.origin[1], o.width * r, o.height * r);
    ctx.restore();
  }

  // In screen pixels: zones, walls, the shape being drawn, the rooms' names.
  drawScreen(ctx, view) {
    const shape = (points, closed) => {
      ctx.beginPath();
      points.forEach(([x, y], i) => {
        const [sx, sy] = view.worldToScreen(x, y);
        if (i === 0) ctx.moveTo(sx, sy);
        else ctx.lineTo(sx, sy);
      });
      if (closed) ctx.closePath();
    };
    ctx.save();
    ctx.strokeStyle = ZONE_EDGE;
    ctx.fillStyle = ZONE_FILL;
    for (const zone of this.zones) {
      shape(zone.points, zone.kind === "zone");
      ctx.lineWidth = zone.kind === "wall" ? 4 : 2;
      if (zone.kind === "zone") ctx.fill();
      ctx.stroke();
    }
    if (this.draft?.points.length) {
      ctx.setLineDash([6, 4]);
      ctx.lineWidth = 2;
      shape(this.draft.points, false);
      ctx.stroke();
      ctx.setLineDash([]);
      for (const [x, y] of this.draft.points) {
        const [sx, sy] = view.worldToScreen(x, y);
        ctx.fillStyle = ZONE_EDGE;
        ctx.fillRect(sx - 3, sy - 3, 6, 6);
      }
    }
    ctx.font = "600 13px system-ui, sans-serif";
    ctx.textAlign = "center";
    ctx.textBaseline = "middle";
    for (const room of this.overlay?.rooms ?? []) {
      const [sx, sy] = view.worldToScreen(room.label[0], room.label[1]);
      ctx.lineWidth = 3;
      ctx.strokeStyle = "rgba(255, 255, 255, 0.9)";
      ctx.strokeText(room.name, sx, sy);
      ctx.fillStyle = "#1f2937";
      ctx.fillText(room.name, sx, sy);
    }
    ctx.restore();
  }
}
