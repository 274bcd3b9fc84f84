// Mapping sessions (app/api/routes/sessions.py): save the session so far under a name, continue one
// (mapping goes on in its map once the robot is found in it), delete. Errors land in the status bar.

function button(text, className, onClick) {
  const node = document.createElement("button");
  Object.assign(node, { type: "button", textContent: text, className });
  node.addEventListener("click", onClick);
  return node;
}

export class SessionsPanel {
  constructor({ api, notify, fail, root = document }) {
    this.api = api;
    this.notify = notify; // (message) => void
    this.fail = fail; // (error) => void
    this.form = root.getElementById("session-form");
    this.name = root.getElementById("session-name");
    this.list = root.getElementById("sessions");
    this.form.addEventListener("submit", (e) => {
      e.preventDefault();
      this.save();
    });
  }

  async run(action, success) {
    try {
      const result = await action();
      if (success) this.notify(success);
      return result;
    } catch (err) {
      this.fail(err);
      return undefined;
    }
  }

  async save() {
    const name = this.name.value.trim();
    if (!name) {
      this.fail(new Error("type a name for the session first"));
      this.name.focus();
      return;
    }
    const saved = await this.run(() => this.api.saveSession(name), `Session saved as "${name}"`);
    if (saved) this.name.value = "";
    await this.refresh();
  }

  async refresh() {
    const sessions = await this.run(() => this.api.sessions());
    if (!sessions) return;
    const items = sessions.map(({ name, saved }) => {
      const li = document.createElement("li");
      li.className = "session";
      li.dataset.name = name;
      const label = document.createElement("span");
      label.className = "name";
      label.textContent = `${name} `;
      const when = document.createElement("span");
      when.className = "sub";
      when.textContent = new Date(saved * 1000).toLocaleDateString();
      label.append(when);
      const resume = button("Continue", "primary", () =>
        this.run(() => this.api.resumeSession(name), `Continuing "${name}": finding the robot in its map`));
      resume.title = "Map on in this session's map";
      const del = button("Delete", "danger", async () => {
        await this.run(() => this.api.deleteSession(name), `Session "${name}" deleted`);
        await this.refresh();
      });
      li.append(label, resume, del);
      return li;
    });
    if (!items.length) {
      const empty = document.createElement("li");
      Object.assign(empty, { className: "empty", textContent: "No saved sessions yet." });
      items.push(empty);
    }
    this.list.replaceChildren(...items);
  }
}
