// arduinoio monitor page: renders what the server pushes over one WebSocket and sends
// controls back.  There is no polling: snapshots ("board") and live data ("samples")
// arrive when the server has them; a lost connection is re-opened with a back-off.
"use strict";

(function () {
  const WINDOW_S = 10;            // seconds of analog history in the plot
  const VREF = 5.0;               // AVCC of an Uno: raw 0-1023 -> volts
  const COLORS = ["#2563eb", "#dc2626", "#16a34a", "#d97706", "#7c3aed", "#0891b2"];
  const ROLE_LABELS = {
    free: "free", input: "input", input_pullup: "input, pull-up", output: "output",
    soft_pwm: "software PWM", servo: "servo PWM", duty: "duty-cycle PWM",
    counter_rising: "counter (rising)", counter_falling: "counter (falling)",
  };

  const boards = {};              // key -> view state
  const pending = new Map();      // request id -> {board, resolve}
  let socket = null;
  let nextId = 1;
  let backoff = 500;

  window.arduinoioMonitor = { boards };

  // ---- connection --------------------------------------------------------------------

  function connect() {
    const scheme = location.protocol === "https:" ? "wss" : "ws";
    socket = new WebSocket(`${scheme}://${location.host}/ws${location.search}`);
    setConnection("connecting", "connecting…");
    socket.onopen = () => { backoff = 500; setConnection("open", "live"); };
    socket.onmessage = (event) => handle(JSON.parse(event.data));
    socket.onclose = () => {
      setConnection("closed", "disconnected, reconnecting…");
      for (const [, req] of pending) req.resolve({ ok: false, error: "connection lost" });
      pending.clear();
      setTimeout(connect, backoff);
      backoff = Math.min(backoff * 2, 5000);
    };
  }

  function setConnection(state, text) {
    const el = document.getElementById("connection");
    el.dataset.state = state;
    el.textContent = text;
  }

  function request(boardKey, op, args) {
    return new Promise((resolve) => {
      if (!socket || socket.readyState !== WebSocket.OPEN) {
        resolve({ ok: false, error: "not connected" });
        return;
      }
      const id = nextId++;
      pending.set(id, { board: boardKey, resolve });
      socket.send(JSON.stringify({ id, board: boardKey, op, ...args }));
    });
  }

  // One request in flight per control; the newest value waits for it (a dragged slider
  // sends as fast as the board answers, never a backlog).
  function latestOnly(send) {
    let busy = false, queued = null;
    return async function push(value) {
      if (busy) { queued = value; return; }
      busy = true;
      try {
        let current = value;
        for (;;) {
          await send(current);
          if (queued === null) break;
          current = queued; queued = null;
        }
      } finally { busy = false; }
    };
  }

  function handle(message) {
    if (message.type === "board") renderBoard(message);
    else if (message.type === "samples") applySamples(message);
    else if (message.type === "result") {
      const req = pending.get(message.id);
      if (req) { pending.delete(message.id); req.resolve(message); }
    }
  }

  async function control(view, op, args, describe) {
    const result = await request(view.key, op, args || {});
    showMessage(view, result.ok ? (describe ? describe(result.data) : "") : result.error, !result.ok);
    return result;
  }

  function showMessage(view, text, isError) {
    const el = view.root.querySelector(".message");
    el.textContent = text || "";
    el.dataset.error = isError ? "true" : "false";
  }

  // ---- building a board's section ----------------------------------------------------

  function createBoard(snapshot) {
    const root = document.getElementById("board-template").content.firstElementChild.cloneNode(true);
    root.dataset.board = snapshot.key;
    document.getElementById("boards").appendChild(root);
    const view = { key: snapshot.key, root, pins: {}, plot: null, data: null, frame: 0, snapshot };
    boards[snapshot.key] = view;

    const tbody = root.querySelector("tbody.pins, table.pins tbody");
    for (const pin of snapshot.pins) {
      const row = document.createElement("tr");
      row.dataset.pin = pin.name;
      row.innerHTML = `<td class="name">${pin.name}</td><td><span class="led" data-level=""></span></td>` +
        `<td class="edges">0 / 0</td><td><select class="role"></select></td><td><div class="control"></div></td>`;
      const select = row.querySelector("select.role");
      for (const role of pin.roles) {
        const option = document.createElement("option");
        option.value = role;
        option.textContent = ROLE_LABELS[role] || role;
        select.appendChild(option);
      }
      // A role given by another program or client: shown, not chosen (choosing another
      // role takes the pin over).
      const elsewhere = document.createElement("option");
      elsewhere.value = "elsewhere"; elsewhere.disabled = true; elsewhere.hidden = true;
      select.appendChild(elsewhere);
      select.addEventListener("change", async () => {
        const result = await control(view, "role", { pin: pin.name, role: select.value },
          () => `${pin.name} is now ${ROLE_LABELS[select.value] || select.value}`);
        if (!result.ok) select.value = view.pins[pin.name].role;
      });
      tbody.appendChild(row);
      view.pins[pin.name] = { row, role: null, led: row.querySelector(".led"), edges: row.querySelector(".edges") };
    }

    root.querySelector(".reset").addEventListener("click", () =>
      control(view, "reset", {}, () => "board reset; roles restored"));
    const timeout = root.querySelector(".failsafe-timeout");
    root.querySelector(".failsafe-arm").addEventListener("click", () =>
      control(view, "failsafe_arm", { timeout_ms: Number(timeout.value) }, () => "failsafe armed"));
    root.querySelector(".failsafe-rearm").addEventListener("click", () =>
      control(view, "failsafe_rearm", {}, () => "failsafe re-armed, outputs restored"));
    root.querySelector(".failsafe-disarm").addEventListener("click", () =>
      control(view, "failsafe_disarm", {}, () => "failsafe disarmed"));

    const form = root.querySelector("form.i2c");
    const i2cArgs = () => ({
      address: Number(form.address.value), register: Number(form.register.value),
      speed: Number(form.speed.value),
    });
    const i2cResult = form.querySelector(".i2c-result");
    form.querySelector(".i2c-read").addEventListener("click", async () => {
      const r = await control(view, "i2c_read", { ...i2cArgs(), length: Number(form.length.value) });
      i2cResult.textContent = r.ok ? `read: ${r.data}` : "";
    });
    form.querySelector(".i2c-write").addEventListener("click", async () => {
      const r = await control(view, "i2c_write", { ...i2cArgs(), data: form.data.value });
      i2cResult.textContent = r.ok ? `wrote ${r.data} bytes` : "";
    });

    const motors = root.querySelector("form.motors");
    motors.querySelector(".motor-add").addEventListener("click", () => {
      const pin = (input) => input.value.trim().toUpperCase();
      const args = motors.kind.value === "2pwm"
        ? { kind: "2pwm", in1: pin(motors.in1), in2: pin(motors.in2) }
        : { kind: "dir", pwm: pin(motors.pwm), in1: pin(motors.in1), in2: pin(motors.in2) };
      control(view, "motor", args, (index) => `motor ${index} set up`);
    });

    const spi = root.querySelector("form.spi");
    spi.querySelector(".spi-add").addEventListener("click", () =>
      control(view, "spi", { cs: spi.cs.value.trim().toUpperCase(), mode: Number(spi.mode.value), clock_hz: Number(spi.clock.value) },
        () => `SPI on ${spi.cs.value}`));
    spi.querySelector(".spi-transfer").addEventListener("click", () =>
      control(view, "spi_transfer", { data: spi.data.value }, (received) => `SPI received ${received}`));
    spi.querySelector(".spi-release").addEventListener("click", () =>
      control(view, "spi_release", {}, () => "SPI released"));
    const encoders = root.querySelector("form.encoders");
    encoders.querySelector(".encoder-add").addEventListener("click", () =>
      control(view, "encoder",
        { a: encoders.a.value.trim().toUpperCase(), b: encoders.b.value.trim().toUpperCase(), mode: encoders.mode.value },
        (slot) => `encoder ${encoders.a.value}/${encoders.b.value} in slot ${slot}`));
    const rc = root.querySelector("form.rc-inputs");
    rc.querySelector(".rc-add").addEventListener("click", () =>
      control(view, "rc_input", { pin: rc.pin.value.trim().toUpperCase(), timeout_ms: Number(rc.timeout.value) },
        (slot) => `RC input ${rc.pin.value} in slot ${slot}`));

    const sonars = root.querySelector("form.sonars");
    sonars.querySelector(".sonar-add").addEventListener("click", () =>
      control(view, "sonar",
        { trigger: sonars.trigger.value.trim().toUpperCase(), echo: sonars.echo.value.trim().toUpperCase() },
        (slot) => `sonar ${sonars.trigger.value}/${sonars.echo.value} in slot ${slot}`));

    const imu = root.querySelector("form.imu");
    imu.querySelector(".imu-add").addEventListener("click", () =>
      control(view, "imu",
        { address: Number(imu.address.value), accel_g: Number(imu.accel_g.value), gyro_dps: Number(imu.gyro_dps.value) },
        (what) => what));

    createPlot(view, snapshot.analog_pins);
    return view;
  }

  function createPlot(view, channels) {
    const container = view.root.querySelector(".plot");
    view.channels = channels;
    view.data = [[], ...channels.map(() => [])];
    const series = [{}, ...channels.map((name, i) => ({
      label: name, stroke: COLORS[i % COLORS.length], width: 1.5,
      value: (u, v) => (v == null ? "–" : v.toFixed(3) + " V"),
    }))];
    const width = Math.max(320, container.clientWidth || 520);
    view.plot = new uPlot({
      width, height: 220, series, legend: { show: false },
      scales: { y: { range: [0, VREF] } },
      axes: [{}, { size: 45 }],
    }, view.data, container);
    const list = view.root.querySelector(".readouts");
    channels.forEach((name, i) => {
      const li = document.createElement("li");
      li.dataset.channel = name;
      li.innerHTML = `<span class="swatch" style="background:${COLORS[i % COLORS.length]}"></span>` +
        `${name} <span class="value" data-raw="">–</span>`;
      list.appendChild(li);
    });
    new ResizeObserver(() => {
      const w = container.clientWidth;
      if (w && Math.abs(w - view.plot.width) > 4) view.plot.setSize({ width: w, height: 220 });
    }).observe(container);
  }

  // ---- snapshots -----------------------------------------------------------------------

  function renderBoard(snapshot) {
    const view = boards[snapshot.key] || createBoard(snapshot);
    view.snapshot = snapshot;
    const root = view.root;
    root.dataset.boardId = snapshot.id;
    root.querySelector(".title").textContent =
      `Board 0x${snapshot.id.toString(16).toUpperCase().padStart(4, "0")}` + (snapshot.connected ? "" : " (disconnected)");
    const fact = (name) => root.querySelector(`[data-fact="${name}"]`);
    fact("port").textContent = snapshot.port;
    fact("firmware").textContent = `${snapshot.firmware} (protocol ${snapshot.protocol})`;
    fact("baud").textContent = snapshot.baud;
    fact("failsafe").textContent = snapshot.failsafe;
    fact("failsafe").dataset.tripped = snapshot.failsafe_tripped ? "true" : "false";
    renderStream(view, snapshot.stream);
    renderChanges(view, snapshot.changes);
    const steppers = snapshot.steppers || { supported: false, rows: [] };
    fact("steppers").textContent = !steppers.supported ? "not in this firmware" : steppers.rows.map((s) =>
      `stepper ${s.index} (${s.pins}): ${s.position} -> ${s.target}` +
      (s.moving ? `, ${s.speed} steps/s` : ", at rest")).join("; ") || "none";
    for (const pin of snapshot.pins) renderPin(view, pin);
    renderEncoders(view, snapshot.encoders);
    renderSonars(view, snapshot.sonars);
    renderMotors(view, snapshot.motors);
    renderSpi(view, snapshot.spi);
    renderImu(view, snapshot.imu);
    renderRcInputs(view, snapshot.rc_inputs);
  }

  // RC inputs: width (us) and stick position, or the lost signal with the last width.
  function renderRcInputs(view, inputs) {
    const form = view.root.querySelector("form.rc-inputs");
    const list = form.querySelector(".rc-rows");
    form.dataset.supported = inputs && inputs.supported ? "true" : "false";
    if (!inputs || !inputs.supported) {
      list.replaceChildren(Object.assign(document.createElement("li"), { textContent: "not in this firmware" }));
      return;
    }
    list.replaceChildren(...inputs.rows.map((r) => Object.assign(document.createElement("li"), {
      textContent: r.lost ? `slot ${r.slot} (${r.pin}): signal lost (last ${r.width_us} us)`
        : `slot ${r.slot} (${r.pin}): ${r.width_us} us · position ${r.position}`,
    })));
  }

  // DC motors: a speed slider (-100..100 %), brake and coast; the state the board was given.
  function renderMotors(view, motors) {
    const list = view.root.querySelector("form.motors .motor-rows");
    const rows = (motors && motors.rows) || [];
    const shown = Array.from(list.children).map((li) => li.dataset.key).join(",");
    if (shown === rows.map((m) => `${m.index}:${m.pins}`).join(",")) {
      for (const m of rows) {  // the same motors: only their readings change
        const li = list.querySelector(`li[data-index="${m.index}"]`);
        li.querySelector(".motor-state").textContent = `${m.state} ${Math.round(m.speed * 100)} %`;
      }
      return;
    }
    list.replaceChildren(...rows.map((m) => {
      const li = document.createElement("li");
      li.dataset.index = m.index;
      li.dataset.key = `${m.index}:${m.pins}`;
      const label = Object.assign(document.createElement("span"), { textContent: `motor ${m.index} (${m.pins}) ` });
      const slider = Object.assign(document.createElement("input"),
        { type: "range", min: -100, max: 100, step: 1, value: Math.round(m.speed * 100), className: "motor-speed" });
      const send = latestOnly((value) => request(view.key, "motor_speed", { index: m.index, speed: value / 100 }));
      slider.addEventListener("input", () => send(Number(slider.value)));
      const state = Object.assign(document.createElement("output"), { className: "motor-state", textContent: `${m.state} ${Math.round(m.speed * 100)} %` });
      const brake = Object.assign(document.createElement("button"), { type: "button", textContent: "Brake" });
      brake.addEventListener("click", () => { slider.value = 0; control(view, "motor_brake", { index: m.index }); });
      const coast = Object.assign(document.createElement("button"), { type: "button", textContent: "Coast" });
      coast.addEventListener("click", () => { slider.value = 0; control(view, "motor_coast", { index: m.index }); });
      li.append(label, slider, state, brake, coast);
      return li;
    }));
  }

  // SPI: the bus's settings and the last transfer made from the page.
  function renderSpi(view, spi) {
    const form = view.root.querySelector("form.spi");
    const list = form.querySelector(".spi-rows");
    form.dataset.supported = spi && spi.supported ? "true" : "false";
    if (!spi || !spi.supported) {
      list.replaceChildren(Object.assign(document.createElement("li"), { textContent: "not in this firmware" }));
      return;
    }
    list.replaceChildren(...spi.rows.map((b) => {
      const li = document.createElement("li");
      const last = b.sent ? ` · sent ${b.sent} · received ${b.received}` : "";
      li.textContent = `CS ${b.cs} · mode ${b.mode} · ${b.clock_hz / 1e6} MHz${b.lsb_first ? " · LSB first" : ""}${last}`;
      return li;
    }));
  }

  // IMU: the three accel (m/s^2) and three gyro (rad/s) traces, read every 0.2 s.
  const IMU_POINTS = 300;
  function renderImu(view, imu) {
    const form = view.root.querySelector("form.imu");
    const out = form.querySelector(".imu-reading");
    if (!imu || !imu.rows.length) return;
    const r = imu.rows[0];
    out.textContent = `accel ${r.accel.map((a) => a.toFixed(2)).join(" ")} m/s² · ` +
      `gyro ${r.gyro.map((w) => w.toFixed(3)).join(" ")} rad/s · ${r.temperature_c} °C`;
    if (!view.imuPlot) {
      const names = ["ax", "ay", "az", "gx", "gy", "gz"];
      view.imuData = [[], ...names.map(() => [])];
      view.imuPlot = new uPlot({
        width: Math.max(320, form.clientWidth || 520), height: 180, legend: { show: true },
        series: [{}, ...names.map((label, i) => ({
          label, stroke: COLORS[i % COLORS.length], width: 1.5, scale: i < 3 ? "accel" : "gyro",
        }))],
        axes: [{}, { scale: "accel", size: 45 }, { scale: "gyro", side: 1, size: 45 }],
      }, view.imuData, form.querySelector(".imu-plot"));
    }
    const values = [...r.accel, ...r.gyro];
    view.imuData[0].push(Date.now() / 1000);
    values.forEach((v, i) => view.imuData[i + 1].push(v));
    if (view.imuData[0].length > IMU_POINTS) view.imuData.forEach((s) => s.shift());
    view.imuPlot.setData(view.imuData);
  }

  // Encoders: count, velocity (counts/s from the board's edge times), invalid transitions.
  function renderEncoders(view, encoders) {
    const form = view.root.querySelector("form.encoders");
    const list = form.querySelector(".encoder-rows");
    form.dataset.supported = encoders && encoders.supported ? "true" : "false";
    if (!encoders || !encoders.supported) {
      list.replaceChildren(Object.assign(document.createElement("li"), { textContent: "not in this firmware" }));
      return;
    }
    list.replaceChildren(...encoders.rows.map((e) => {
      const li = document.createElement("li");
      li.dataset.slot = e.slot;
      const text = document.createElement("span");
      text.className = "encoder-reading";
      text.textContent = `slot ${e.slot} (${e.pins}): ${e.count} · ${e.velocity} /s · ${e.invalid} invalid`;
      const reset = Object.assign(document.createElement("button"), { type: "button", textContent: "Reset" });
      reset.addEventListener("click", () => control(view, "encoder_reset", { slot: e.slot }, () => `encoder ${e.slot} reset`));
      li.append(text, reset);
      return li;
    }));
  }

  // Sonars: the board's latest distance of each (or "no echo"), its age and readings.
  function renderSonars(view, sonars) {
    const form = view.root.querySelector("form.sonars");
    const list = form.querySelector(".sonar-rows");
    form.dataset.supported = sonars && sonars.supported ? "true" : "false";
    if (!sonars || !sonars.supported) {
      list.replaceChildren(Object.assign(document.createElement("li"), { textContent: "not in this firmware" }));
      return;
    }
    list.replaceChildren(...sonars.rows.map((s) => {
      const what = s.distance_mm !== null ? `${s.distance_mm} mm` : s.no_echo ? "no echo" : "waiting";
      return Object.assign(document.createElement("li"), {
        className: "sonar-reading",
        textContent: `slot ${s.slot} (${s.pins}): ${what} · ${s.age_ms} ms ago · ${s.readings} readings`,
      });
    }));
  }

  function renderStream(view, stream) {
    const el = view.root.querySelector('[data-fact="stream"]');
    el.dataset.running = stream.running ? "true" : "false";
    el.textContent = !stream.enabled ? "off (inputs: change events only)" : stream.running
      ? `${stream.period_ms} ms · ${stream.channels.join(" ") || "levels"} · ${stream.received} samples, ${stream.lost} lost`
      : `stopped${stream.error ? ": " + stream.error : ""}`;
  }

  // Inputs watched for change events: every edge counted, losses from sequence numbers.
  function renderChanges(view, changes) {
    const el = view.root.querySelector('[data-fact="changes"]');
    el.dataset.running = changes.running ? "true" : "false";
    el.textContent = changes.running
      ? `${changes.pins.join(" ") || "no inputs"} · ${changes.received} events, ${changes.lost} lost`
      : changes.error || "stopped";
  }

  function renderPin(view, pin) {
    const state = view.pins[pin.name];
    const select = state.row.querySelector("select.role");
    const elsewhere = select.querySelector('option[value="elsewhere"]');
    elsewhere.hidden = pin.role !== "elsewhere";
    elsewhere.textContent = pin.elsewhere ? `${pin.elsewhere} (set elsewhere)` : "";
    state.row.dataset.elsewhere = pin.elsewhere || "";
    if (document.activeElement !== select) select.value = pin.role;
    const box = state.row.querySelector(".control");
    if (state.role !== pin.role || state.elsewhere !== pin.elsewhere) {
      state.elsewhere = pin.elsewhere;
      state.role = pin.role;
      box.replaceChildren(...buildControl(view, pin));
    }
    if (pin.role === "output") {
      const toggle = box.querySelector("input.out");
      if (document.activeElement !== toggle) toggle.checked = pin.value === 1;
    } else if (pin.role === "servo" || pin.role === "soft_pwm") {
      const slider = box.querySelector("input.pulse");
      if (document.activeElement !== slider && pin.value) slider.value = pin.value;
      // No pulses: the slider says so (greyed) instead of standing at a width not sent.
      slider.classList.toggle("off", !pin.value);
      box.querySelector("output").textContent = pin.value ? `${pin.value} µs` : "off";
    } else if (pin.role === "duty") {
      const slider = box.querySelector("input.duty");
      if (document.activeElement !== slider) slider.value = pin.value;
      box.querySelector("output").textContent = `${(pin.value / 10).toFixed(1)} %`;
    }
  }

  function buildControl(view, pin) {
    const key = pin.name;
    if (pin.role === "output") {
      const label = document.createElement("label");
      label.innerHTML = `<input type="checkbox" class="out"> high`;
      const toggle = label.querySelector("input");
      toggle.addEventListener("change", () =>
        control(view, "write", { pin: key, value: toggle.checked ? 1 : 0 }));
      return [label];
    }
    if (pin.role === "servo" || pin.role === "soft_pwm") {
      const slider = document.createElement("input");
      slider.type = "range"; slider.className = "pulse";
      slider.min = 1000; slider.max = 2000; slider.step = pin.role === "servo" ? 1 : 100;
      slider.value = pin.value || 1500;
      slider.classList.toggle("off", !pin.value);
      slider.title = "pulse width; greyed while no pulses go out";
      const shown = document.createElement("output");
      shown.textContent = pin.value ? `${pin.value} µs` : "off";
      const send = latestOnly((us) => control(view, "pulse", { pin: key, us }));
      slider.addEventListener("input", () => {
        slider.classList.remove("off");
        shown.textContent = `${slider.value} µs`;
        send(Number(slider.value));
      });
      const off = document.createElement("button");
      off.type = "button"; off.textContent = "off"; off.className = "pulse-off";
      off.addEventListener("click", () => send(0));
      return [slider, shown, off];
    }
    if (pin.role === "elsewhere") {
      const note = document.createElement("span");
      note.className = "elsewhere";
      note.textContent = "set by another program or client";
      return [note];
    }
    if (pin.role === "duty") {
      const slider = document.createElement("input");
      slider.type = "range"; slider.className = "duty";
      slider.min = 0; slider.max = 1000; slider.step = 1;
      slider.value = pin.value || 0;
      const shown = document.createElement("output");
      const send = latestOnly((permille) => control(view, "duty", { pin: key, permille }));
      slider.addEventListener("input", () => {
        shown.textContent = `${(slider.value / 10).toFixed(1)} %`; send(Number(slider.value));
      });
      return [slider, shown];
    }
    if (pin.role.startsWith("counter_")) {
      const clear = document.createElement("button");
      clear.type = "button"; clear.textContent = "clear count";
      clear.addEventListener("click", () =>
        control(view, "counter_reset", { pin: key }, (count) => `${key} counter cleared at ${count}`));
      return [clear];
    }
    return [];
  }

  // ---- live data -------------------------------------------------------------------------

  function applySamples(message) {
    const view = boards[message.board];
    if (!view) return;
    for (const [name, state] of Object.entries(view.pins)) {
      // The level masks are 32-bit numbers here: a Mega's pins above D30 have no bit
      // (the stream's and the change events' masks carry D0-D15 today).
      const number = Number(name.slice(1));
      const bit = number <= 30 ? 1 << number : 0;
      // data-source says where the level comes from: "changes" (pushed events) or "stream".
      state.row.dataset.source = message.watched & bit ? "changes" : message.known & bit ? "stream" : "";
      state.led.dataset.level = message.known & bit ? (message.levels & bit ? "1" : "0") : "";
      if ((message.rose | message.fell) & bit) blink(state.led);
    }
    const pinNames = Object.keys(view.pins);
    pinNames.forEach((name, i) => {
      view.pins[name].edges.textContent = `${message.rises[i]} / ${message.falls[i]}`;
    });
    view.root.querySelectorAll("[data-counter]").forEach((el) => {
      const index = Number(el.dataset.counter);
      const value = message.counters[index];
      el.textContent = value === null ? "–" : value;
      // "reports": the board reports this counter as it counts (counter reports).
      el.dataset.source = message.reported & (1 << (index + 2)) ? "reports" : "";
    });
    renderStream(view, message.stream);
    renderChanges(view, message.changes);
    if (message.t.length) appendAnalog(view, message);
  }

  function blink(led) {
    led.classList.add("blink");
    clearTimeout(led.blinkTimer);
    led.blinkTimer = setTimeout(() => led.classList.remove("blink"), 150);
  }

  function appendAnalog(view, message) {
    const data = view.data;
    data[0].push(...message.t);
    view.channels.forEach((name, i) => {
      const values = message.analog[name];
      const column = data[i + 1];
      const readout = view.root.querySelector(`.readouts [data-channel="${name}"] .value`);
      if (values) {
        for (const raw of values) column.push(raw * VREF / 1024);
        const last = values[values.length - 1];
        readout.dataset.raw = last;
        readout.textContent = `${(last * VREF / 1024).toFixed(3)} V`;
      } else {
        for (let k = 0; k < message.t.length; k++) column.push(null);
        readout.dataset.raw = "";
        readout.textContent = "in use (I2C)";
      }
    });
    const cutoff = data[0][data[0].length - 1] - WINDOW_S;
    let drop = 0;
    while (drop < data[0].length && data[0][drop] < cutoff) drop++;
    if (drop) for (const column of data) column.splice(0, drop);
    if (!view.frame) {
      view.frame = requestAnimationFrame(() => { view.frame = 0; view.plot.setData(view.data); });
    }
  }

  connect();
})();
