// The sidebar: mode switch, mapping pause/resume, named places (add, go, rename, delete) and saved maps
// (save as, load for localization, delete). Every action goes through the REST API; errors land in the
// status bar's "last error".

function el(tag, props = {}, ...children) {
  const node = document.createElement(tag);
  Object.assign(node, props);
  node.append(...children);
  return node;
}

export class Panels {
  constructor({ api, state, notify, fail, onPickPlace, root = document }) {
    this.api = api;
    this.state = state;
    this.notify = notify; // (message) => void
    this.fail = fail; // (error) => void
    this.onPickPlace = onPickPlace; // () => void: the map's "place" tool
    this.modes = root.getElementById("modes");
    this.modeMap = root.getElementById("mode-map");
    this.mappingToggle = root.getElementById("mapping-toggle");
    this.tourRestart = root.getElementById("tour-restart");
    this.placeForm = root.getElementById("place-form");
    this.placeName = root.getElementById("place-name");
    this.placesList = root.getElementById("places");
    this.mapForm = root.getElementById("map-form");
    this.mapName = root.getElementById("map-name");
    this.mapsList = root.getElementById("maps");
    this.landmarksLayer = root.querySelector("[data-layer=landmarks]");

    for (const button of this.modes.querySelectorAll("[data-mode]")) {
      button.addEventListener("click", () => this.setMode(button.dataset.mode));
    }
    this.mappingToggle.addEventListener("click", () => this.toggleMapping());
    root.getElementById("new-map").addEventListener("click", () => this.startNewMap());
    this.tourRestart.addEventListener("click", () => this.run(() => this.api.restartTour(), "Tour restarted"));
    this.placeForm.addEventListener("submit", (e) => {
      e.preventDefault();
      this.addPlaceAtRobot();
    });
    root.getElementById("place-pick").addEventListener("click", () => {
      if (this.placeNameOrComplain()) this.onPickPlace();
    });
    this.mapForm.addEventListener("submit", (e) => {
      e.preventDefault();
      this.saveMap();
    });
  }

  async run(action, success) {
    try {
      const result = await action();
      if (success) this.notify(typeof success === "function" ? success(result) : success);
      return result;
    } catch (err) {
      this.fail(err);
      return undefined;
    }
  }

  renderMode() {
    const s = this.state.status;
    for (const button of this.modes.querySelectorAll("[data-mode]")) {
      button.setAttribute("aria-checked", String(s?.mode === button.dataset.mode));
    }
    const paused = s?.mapping === false;
    this.mappingToggle.textContent = paused ? "Resume mapping" : "Pause mapping";
    this.mappingToggle.disabled = s?.mode !== "mapping";
    // Shown only where they do something: the map choice for localization, landmarks in EKF mode.
    this.modeMap.closest("label").hidden = s?.mode !== "localization";
    this.landmarksLayer.closest("label").hidden = s?.mode !== "ekf";
    this.tourRestart.hidden = s?.sim !== true; // only the simulated home has a tour
  }

  async setMode(mode) {
    const map = mode === "localization" ? this.modeMap.value || undefined : undefined;
    const status = await this.run(() => this.api.setMode(mode, map), `Mode: ${mode}`);
    if (status) this.state.handle({ type: "status", ...status });
  }

  // Every mode switch keeps the map; only this throws it away, and only once the person confirms.
  async startNewMap() {
    if (!window.confirm("Start a new, empty map? The current map is lost unless you save it first (Saved maps).")) return;
    const status = await this.run(() => this.api.setMode("mapping", undefined, true), "New map started");
    if (status) this.state.handle({ type: "status", ...status });
  }

  async toggleMapping() {
    const paused = this.state.status?.mapping === false;
    const status = await this.run(
      () => (paused ? this.api.startMapping() : this.api.stopMapping()),
      paused ? "Mapping resumed" : "Mapping paused: the map is frozen",
    );
    if (status) this.state.handle({ type: "status", ...status });
  }

  // Places ---------------------------------------------------------------------------------------

  placeNameOrComplain() {
    const name = this.placeName.value.trim();
    if (!name) {
      this.fail(new Error("type a name for the place first"));
      this.placeName.focus();
      return null;
    }
    return name;
  }

  async addPlaceAtRobot() {
    const name = this.placeNameOrComplain();
    const pose = this.state.pose ?? this.state.status?.pose;
    if (!name) return;
    if (!pose) {
      this.fail(new Error("the robot's pose is not known yet"));
      return;
    }
    await this.addPlace(name, pose.x, pose.y, pose.yaw);
  }

  async addPlace(name, x, y, yaw) {
    const created = await this.run(() => this.api.addPlace(name, x, y, yaw ?? 0), `Place "${name}" added`);
    if (created) this.placeName.value = "";
    await this.refreshPlaces();
  }

  async refreshPlaces() {
    const places = await this.run(() => this.api.places());
    if (!places) return;
    this.state.places = places;
    this.state.changed("places");
    this.renderPlaces();
  }

  renderPlaces() {
    const items = this.state.places.map((place) => {
      const li = el("li", { className: "place" });
      li.dataset.name = place.name;
      const label = el("span", { className: "name", title: "rename" }, place.name,
        el("span", { className: "sub coords" }, `(${place.x.toFixed(1)}, ${place.y.toFixed(1)})`));
      const go = el("button", { type: "button", textContent: "Go", className: "primary" });
      go.addEventListener("click", () => this.run(() => this.api.goToPlace(place.name), `Going to ${place.name}`));
      const rename = el("button", { type: "button", textContent: "Rename" });
      rename.addEventListener("click", () => this.editPlace(li, place));
      const del = el("button", { type: "button", textContent: "Delete", className: "danger" });
      del.addEventListener("click", () => this.confirmThen(del, async () => {
        await this.run(() => this.api.deletePlace(place.name), `Place "${place.name}" deleted`);
        await this.refreshPlaces();
      }));
      li.append(label, go, rename, del);
      return li;
    });
    if (!items.length) items.push(el("li", { className: "empty", textContent: "No places yet." }));
    this.placesList.replaceChildren(...items);
  }

  editPlace(li, place) {
    const input = el("input", { value: place.name, maxLength: 64, ariaLabel: "New name" });
    const save = el("button", { type: "submit", textContent: "Save", className: "primary" });
    const cancel = el("button", { type: "button", textContent: "Cancel" });
    const form = el("form", { className: "row" }, input, save, cancel);
    form.style.margin = "0";
    form.style.flex = "1";
    form.addEventListener("submit", async (e) => {
      e.preventDefault();
      const name = input.value.trim();
      if (name && name !== place.name) {
        await this.run(() => this.api.updatePlace(place.name, { name }), `Renamed to "${name}"`);
      }
      await this.refreshPlaces();
    });
    cancel.addEventListener("click", () => this.renderPlaces());
    li.replaceChildren(form);
    input.focus();
    input.select();
  }

  // A destructive button asks once more: the first click turns it into "Sure?".
  confirmThen(button, action) {
    if (button.dataset.armed) {
      action();
      return;
    }
    button.dataset.armed = "1";
    const label = button.textContent;
    button.textContent = "Sure?";
    setTimeout(() => {
      delete button.dataset.armed;
      button.textContent = label;
    }, 3000);
  }

  // Maps -----------------------------------------------------------------------------------------

  async saveMap() {
    const name = this.mapName.value.trim();
    if (!name) {
      this.fail(new Error("type a name for the map first"));
      this.mapName.focus();
      return;
    }
    const saved = await this.run(() => this.api.saveMap(name), `Map saved as "${name}"`);
    if (saved) this.mapName.value = "";
    await this.refreshMaps();
  }

  async refreshMaps() {
    const maps = await this.run(() => this.api.maps());
    if (!maps) return;
    this.state.maps = maps;
    this.renderMaps();
  }

  renderMaps() {
    const items = this.state.maps.map((map) => {
      const li = el("li", { className: "map" });
      li.dataset.name = map.name;
      const size = map.width && map.resolution ? `${(map.width * map.resolution).toFixed(0)}×${(map.height * map.resolution).toFixed(0)} m` : "";
      const label = el("span", { className: "name" }, map.name, " ", el("span", { className: "sub" }, size));
      const view = el("a", { href: `api/maps/${encodeURIComponent(map.name)}.png`, target: "_blank", rel: "noopener", textContent: "png" });
      const load = el("button", { type: "button", textContent: "Load", className: "primary", title: "Localize on this map" });
      load.addEventListener("click", async () => {
        const status = await this.run(() => this.api.loadMap(map.name), `Loaded "${map.name}": set the robot's pose if it is lost`);
        if (status) this.state.handle({ type: "status", ...status });
      });
      const del = el("button", { type: "button", textContent: "Delete", className: "danger" });
      del.addEventListener("click", () => this.confirmThen(del, async () => {
        await this.run(() => this.api.deleteMap(map.name), `Map "${map.name}" deleted`);
        await this.refreshMaps();
      }));
      li.append(label, view, load, del);
      return li;
    });
    if (!items.length) items.push(el("li", { className: "empty", textContent: "No saved maps yet." }));
    this.mapsList.replaceChildren(...items);

    const selected = this.modeMap.value;
    this.modeMap.replaceChildren(
      el("option", { value: "", textContent: "current map" }),
      ...this.state.maps.map((m) => el("option", { value: m.name, textContent: m.name })),
    );
    if (this.state.maps.some((m) => m.name === selected)) this.modeMap.value = selected;
  }
}
