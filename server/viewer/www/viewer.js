// The Caustica viewer page: a WebSocket to /ws (protocol in docs/viewer.md), progressive frames
// drawn to a canvas, light drags, area-light switches and camera moves sent as JSON.
// window.causticaViewer exposes the state tests read (frames drawn, lights, latencies).
'use strict';

(() => {
  const params = new URLSearchParams(location.search);
  const token = params.get('token') || '';
  const requestedScene = params.get('scene') || '';
  const requestedPasses = Number.parseInt(params.get('passes') || '0', 10) || 0;
  // JPEG strips per frame (1: one JPEG); absent: the server's default.
  const requestedStrips = Number.parseInt(params.get('strips') || '0', 10) || 0;
  const benchMode = params.get('bench');
  const benchMoves = params.has('moves') ? Number(params.get('moves')) : 30;
  // The token stays in memory only: out of the address bar, the history and screenshots.
  if (params.has('token')) {
    params.delete('token');
    const query = params.toString();
    history.replaceState(null, '', location.pathname + (query ? `?${query}` : ''));
  }

  const $ = (id) => document.getElementById(id);
  const canvas = $('frame');
  const context2d = canvas.getContext('2d');
  const viewer = {
    connected: false,
    scenes: [],
    scene: null,        // the open scene's message
    lights: [],         // the scene's lights, then the offered viewer light if any
    emitters: [],       // the scene's emitting materials
    environment: null,  // the scene's environment: its intensity and rotation, or null
    selected: null,     // index of the light the intensity slider scales
    framesDrawn: 0,
    lastFrame: null,    // header of the last frame drawn
    latencies: [],      // ms from sending a light change to drawing the first frame showing it
    errors: [],
    idle: false,        // the picture reached its pass target
  };
  window.causticaViewer = viewer;

  // --- the socket ---
  const socket = new WebSocket(`${location.protocol === 'https:' ? 'wss' : 'ws'}://${location.host}/ws`);
  socket.binaryType = 'arraybuffer';
  let nextId = 1;
  const send = (message) => {
    if (socket.readyState !== WebSocket.OPEN) return 0;
    const id = nextId++;
    socket.send(JSON.stringify({ ...message, id }));
    return id;
  };

  socket.addEventListener('open', () => {
    viewer.connected = true;
    $('connection').textContent = 'connected';
    send({ type: 'hello', token });
  });
  socket.addEventListener('close', () => {
    viewer.connected = false;
    $('connection').textContent = 'disconnected (reload to reconnect)';
  });
  socket.addEventListener('message', (event) => {
    if (typeof event.data === 'string') {
      handleText(JSON.parse(event.data));
    } else {
      handleFrame(event.data, performance.now());
    }
  });

  function showError(message) {
    viewer.errors.push(message);
    const box = $('error');
    box.textContent = `${message.code}: ${message.message}`;
    box.hidden = false;
    if (benchFailed) benchFailed(`${message.code}: ${message.message}`);
    else if (benchMode !== null && !benchStarted) benchError(`${message.code}: ${message.message}`);
  }

  function handleText(message) {
    switch (message.type) {
      case 'scenes': return showScenes(message.scenes);
      case 'scene': return showScene(message);
      case 'updated': return updated(message);
      case 'lights':
        // Another client changed the lights: the page starts again from the scene's new ones.
        showLights(message.lights);
        showEmitters(message.emitters, true);
        showEnvironment(message.environment, true);
        return selectLight(defaultSelection());
      case 'idle':
        // The stream's last frames may still be decoding: idle shows once they are drawn.
        idleReceived = true;
        settleIdle();
        return;
      case 'error':
        settle(message.id);
        return showError(message);
      default:
        return undefined;
    }
  }

  // --- scenes ---
  let opened = false;
  function showScenes(scenes) {
    viewer.scenes = scenes;
    const list = $('scene-list');
    list.replaceChildren();
    for (const scene of scenes) {
      const option = document.createElement('option');
      option.value = scene.id;
      option.textContent = `${scene.name || '(unnamed)'} · ${scene.width}×${scene.height} · ${scene.id}`;
      list.append(option);
    }
    if (scenes.length === 0) {
      const option = document.createElement('option');
      option.textContent = '(no scenes: upload one with `caustica scene upload`)';
      list.append(option);
    }
    list.disabled = $('open-scene').disabled = scenes.length === 0;
    if (!opened && requestedScene) openScene(requestedScene);
  }

  function openScene(id) {
    opened = true;
    $('error').hidden = true;
    send({
      type: 'open', scene: id, ...(requestedPasses ? { passes: requestedPasses } : {}),
      ...(requestedStrips ? { strips: requestedStrips } : {}),
    });
  }
  $('open-scene').addEventListener('click', () => openScene($('scene-list').value));

  function showScene(message) {
    viewer.scene = message;
    idleReceived = false;
    viewer.idle = false;
    // Changes still waiting were meant for the scene before.
    queued = [];
    $('scene-list').value = message.scene.id;
    const url = new URL(location.href);
    url.searchParams.set('scene', message.scene.id);
    history.replaceState(null, '', url);
    canvas.width = message.scene.width;
    canvas.height = message.scene.height;
    fitCanvas();
    $('stage').hidden = $('controls').hidden = false;
    showLights(message.lights);
    showEmitters(message.emitters, true);
    showEnvironment(message.environment, true);
    selectLight(defaultSelection());
  }

  // Small pictures are shown enlarged to fill the window; pointer maths uses the shown size.
  function fitCanvas() {
    const scale = Math.max(1, Math.min((window.innerWidth - 32) / canvas.width,
      (window.innerHeight - 160) / canvas.height));
    canvas.style.width = `${Math.floor(canvas.width * scale)}px`;
    canvas.style.height = `${Math.floor(canvas.height * scale)}px`;
  }
  window.addEventListener('resize', () => { if (viewer.scene) fitCanvas(); });

  // --- lights ---
  function showLights(lights) {
    viewer.lights = lights;
    const offered = lights.find((light) => light.viewer_light);
    const note = $('lights-note');
    note.hidden = !offered;
    note.textContent = offered ?
      'This scene has no point or spot light to drag, so the dashed handle is a viewer point ' +
      'light: its first drag (or the slider) adds it to the scene\'s lights, and the others stay.' : '';
    const box = $('handles');
    box.replaceChildren();
    for (const light of lights) {
      if (!light.draggable || !light.visible) continue;
      const handle = document.createElement('div');
      const at = handleAt(light);
      handle.className = `handle${light.viewer_light ? ' placed' : ''}${at.outside ? ' outside' : ''}` +
        `${light.index === viewer.selected ? ' selected' : ''}`;
      handle.dataset.index = light.index;
      handle.title = `${light.name || light.type} (${light.type}` +
        `${at.outside ? ', outside the picture: drag it in' : ''})`;
      placeHandle(handle, at.u, at.v);
      box.append(handle);
    }
    const list = $('light-list');
    list.replaceChildren();
    for (const light of lights) {
      const item = document.createElement('li');
      const label = document.createElement('label');
      const radio = document.createElement('input');
      radio.type = 'radio';
      radio.name = 'light';
      radio.value = light.index;
      radio.checked = light.index === viewer.selected;
      radio.addEventListener('change', () => selectLight(light.index));
      let what = light.type;
      if (light.viewer_light) what = 'point, offered by the viewer';
      else if (!light.draggable) what = `${light.type}: a direction, no position, so not draggable`;
      else if (!light.visible) what = `${light.type}, behind the camera`;
      label.append(radio, ` ${light.name || `light ${light.index}`} `);
      const kind = document.createElement('span');
      kind.className = 'muted';
      kind.textContent = `(${what})`;
      label.append(kind);
      item.append(label);
      list.append(item);
    }
  }
  // The first light a drag can move, else the first light: what the slider scales at first.
  function defaultSelection() {
    const light = viewer.lights.find((l) => l.draggable) || viewer.lights[0];
    return light ? light.index : null;
  }
  // The slider is in stops around the selected light's intensity when it was selected.
  let intensityBase = null;
  function selectLight(index) {
    viewer.selected = index;
    const light = viewer.lights.find((l) => l.index === index);
    intensityBase = light ? light.intensity : null;
    $('intensity').disabled = !light;
    $('intensity').value = 0;
    $('intensity-value').textContent = light ? `${light.intensity.toPrecision(3)} ${intensityUnit(light)}` : '';
    $('selected-light').textContent = light ? light.name || `light ${light.index}` : 'none';
    for (const handle of $('handles').children) {
      handle.classList.toggle('selected', Number(handle.dataset.index) === index);
    }
    for (const radio of $('light-list').querySelectorAll('input')) radio.checked = Number(radio.value) === index;
  }
  const intensityUnit = (light) => (light.type === 'directional' ? 'W/m²' : 'W/sr');
  $('intensity').addEventListener('input', () => {
    const light = viewer.lights.find((l) => l.index === viewer.selected);
    if (!light || intensityBase === null) return;
    const intensity = intensityBase * 2 ** Number($('intensity').value);
    $('intensity-value').textContent = `${intensity.toPrecision(3)} ${intensityUnit(light)}`;
    change({ type: 'set_intensity', light: light.index, intensity });
  });

  // --- area lights: one row per emitting material, its switch and a radiance slider in stops ---
  const emitterBase = [];  // radiance (brightest channel) each slider is centred on
  function showEmitters(emitters, rebuild) {
    viewer.emitters = emitters;
    $('emitters-panel').hidden = emitters.length === 0;
    const list = $('emitter-list');
    if (rebuild || list.children.length !== emitters.length) {
      list.replaceChildren();
      emitterBase.length = 0;
      for (const emitter of emitters) {
        emitterBase[emitter.index] = emitter.brightness;
        const item = document.createElement('li');
        const label = document.createElement('label');
        const on = document.createElement('input');
        on.type = 'checkbox';
        on.className = 'emitter-on';
        on.addEventListener('change', () => change({ type: 'set_emitter', emitter: emitter.index, on: on.checked }));
        label.append(on, ` ${emitter.material}`);
        const slider = document.createElement('input');
        slider.type = 'range';
        slider.className = 'emitter-radiance';
        slider.min = -4;
        slider.max = 4;
        slider.step = 0.05;
        slider.value = 0;
        slider.title = 'radiance, in stops';
        const value = document.createElement('output');
        slider.addEventListener('input', () => {
          const radiance = emitterBase[emitter.index] * 2 ** Number(slider.value);
          value.textContent = `${radiance.toPrecision(3)} W/(sr·m²)`;
          change({ type: 'set_emitter', emitter: emitter.index, radiance });
        });
        item.append(label, slider, value);
        list.append(item);
      }
    }
    for (const emitter of emitters) {
      const item = list.children[emitter.index];
      item.querySelector('.emitter-on').checked = emitter.on;
      item.querySelector('output').textContent = `${emitter.brightness.toPrecision(3)} W/(sr·m²)`;
      item.classList.toggle('off', !emitter.on);
    }
  }

  // --- the environment: an intensity slider in stops around the scene's and a rotation ---
  let environmentBase = 1;  // the intensity the slider is centred on
  function showEnvironment(environment, rebuild) {
    viewer.environment = environment;
    $('environment-panel').hidden = !environment;
    if (!environment) return;
    if (rebuild) {
      environmentBase = environment.intensity > 0 ? environment.intensity : 1;
      $('environment-intensity').value = 0;
      $('environment-rotation').value = ((environment.rotation + 180) % 360 + 360) % 360 - 180;
    }
    $('environment-intensity-value').textContent = environment.intensity.toPrecision(3);
    $('environment-rotation-value').textContent = `${environment.rotation.toFixed(0)}°`;
  }
  $('environment-intensity').addEventListener('input', () => {
    const intensity = environmentBase * 2 ** Number($('environment-intensity').value);
    $('environment-intensity-value').textContent = intensity.toPrecision(3);
    change({ type: 'set_environment', intensity });
  });
  $('environment-rotation').addEventListener('input', () => {
    const rotation = Number($('environment-rotation').value);
    $('environment-rotation-value').textContent = `${rotation.toFixed(0)}°`;
    change({ type: 'set_environment', rotation });
  });

  // Lights outside the picture get their handle at its edge, towards where they are, so that
  // every light in front of the camera can be picked up.
  const edge = 0.015;
  const clamp = (x) => Math.min(1 - edge, Math.max(edge, x));
  function handleAt(light) {
    const u = clamp(light.u), v = clamp(light.v);
    return { u, v, outside: u !== light.u || v !== light.v };
  }
  function placeHandle(handle, u, v) {
    handle.style.left = `${(u * 100).toFixed(3)}%`;
    handle.style.top = `${(v * 100).toFixed(3)}%`;
  }

  // Changes go one at a time: while one is in flight the newest wanted change of each kind waits,
  // so a fast drag sends the latest position rather than a backlog, and a switch is never lost.
  let inFlight = 0;
  let queued = [];
  const pendingLatency = new Map();  // request id -> {sentAt, epoch}
  const firstDrawn = new Map();      // lights epoch -> its first frame drawn: when, and its timings
  let latencyListener = null;        // the bench's, told of each latency measured
  const lightChanges = new Set(['move_light', 'set_intensity', 'set_emitter', 'set_environment']);

  function change(message) {
    if (inFlight) {
      queue(message);
      return;
    }
    const sentAt = performance.now();
    inFlight = send(message);
    if (lightChanges.has(message.type)) pendingLatency.set(inFlight, { sentAt, epoch: null });
  }
  const changeKey = (message) => `${message.type}:${message.light ?? message.emitter ?? ''}`;
  function queue(message) {
    const at = queued.findIndex((previous) => changeKey(previous) === changeKey(message));
    if (at < 0) {
      queued.push(message);
      return;
    }
    const previous = queued[at];
    if (message.type === 'orbit') {
      queued[at] = { ...message, dx: previous.dx + message.dx, dy: previous.dy + message.dy };
    } else if (message.type === 'zoom') {
      queued[at] = { ...message, steps: previous.steps + message.steps };
    } else {
      // A switch and a radiance for the same emitter travel together.
      queued[at] = { ...previous, ...message };
    }
  }
  function settle(id) {
    if (id && id === inFlight) {
      inFlight = 0;
      if (pendingLatency.has(id) && pendingLatency.get(id).epoch === null) pendingLatency.delete(id);
      if (queued.length) change(queued.shift());
    }
  }

  function updated(message) {
    if (!dragging) showLights(message.lights);
    else viewer.lights = message.lights;
    showEmitters(message.emitters, false);
    showEnvironment(message.environment, false);
    idleReceived = false;
    viewer.idle = false;
    const pending = pendingLatency.get(message.id);
    if (pending && message.what === 'lights') {
      pending.epoch = message.epochs.lights;
      resolveLatencies();
    }
    settle(message.id);
  }

  function resolveLatencies() {
    for (const [id, pending] of pendingLatency) {
      if (pending.epoch === null) continue;
      let drawn = null;
      for (const [epoch, frame] of firstDrawn) {
        if (epoch >= pending.epoch && (drawn === null || frame.drawnAt < drawn.drawnAt)) drawn = frame;
      }
      if (drawn === null) continue;
      const ms = Math.max(0, drawn.drawnAt - pending.sentAt);
      viewer.latencies.push(ms);
      pendingLatency.delete(id);
      const sorted = [...viewer.latencies].sort((a, b) => a - b);
      const median = sorted[Math.floor(sorted.length / 2)];
      $('latency').textContent = `drag → frame: last ${ms.toFixed(0)} ms, median ` +
        `${median.toFixed(0)} ms over ${sorted.length}`;
      if (latencyListener) latencyListener({ ms, sentAt: pending.sentAt, ...drawn });
    }
  }

  // --- frames ---
  // Only the newest frame waits for decoding, so a slow decode skips frames instead of lagging.
  let waitingFrame = null;
  let decoding = false;
  let idleReceived = false;
  function settleIdle() {
    viewer.idle = idleReceived && !decoding && !waitingFrame;
  }
  function handleFrame(buffer, arrivedAt) {
    const view = new DataView(buffer);
    const headerLength = view.getUint32(0, true);
    const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, headerLength)));
    waitingFrame = { header, bytes: new Uint8Array(buffer, 4 + headerLength), arrivedAt };
    // A frame after the idle message belongs to a new stream.
    idleReceived = false;
    viewer.idle = false;
    if (!decoding) drawFrames();
  }
  // Decodes and draws one frame; returns when decoding ended. createImageBitmap decodes off the
  // main thread; the other decoders tried were no faster overall (docs/viewer.md, "Latency").
  // A frame of strips is one JPEG per strip, all decoded at once (the browser runs the decodes
  // concurrently) and drawn one under the other.
  async function showFrame(header, bytes) {
    const sizes = header.strip_bytes || [];
    const parts = [];
    if (sizes.length > 1) {
      let offset = 0;
      for (const size of sizes) {
        parts.push(new Blob([bytes.subarray(offset, offset + size)], { type: header.mime }));
        offset += size;
      }
    } else {
      parts.push(new Blob([bytes], { type: header.mime }));
    }
    const bitmaps = await Promise.all(parts.map((part) => createImageBitmap(part)));
    const decodedAt = performance.now();
    const width = bitmaps[0].width;
    const height = bitmaps.reduce((sum, bitmap) => sum + bitmap.height, 0);
    if (canvas.width !== width || canvas.height !== height) {
      canvas.width = width;
      canvas.height = height;
      fitCanvas();
    }
    let y = 0;
    for (const bitmap of bitmaps) {
      context2d.drawImage(bitmap, 0, y);
      y += bitmap.height;
      bitmap.close();
    }
    return decodedAt;
  }
  async function drawFrames() {
    decoding = true;
    while (waitingFrame) {
      const { header, bytes, arrivedAt } = waitingFrame;
      waitingFrame = null;
      let decodedAt;
      try {
        decodedAt = await showFrame(header, bytes);
      } catch (error) {
        showError({ code: 'DECODE', message: `cannot decode a ${header.encoding} frame: ${error}` });
        continue;
      }
      const drawnAt = performance.now();
      viewer.framesDrawn += 1;
      viewer.lastFrame = header;
      if (!firstDrawn.has(header.epochs.lights)) {
        firstDrawn.set(header.epochs.lights, { drawnAt, arrivedAt, decodedAt, header, bytes: bytes.length });
      }
      resolveLatencies();
      showOverlay(header);
      if (viewer.framesDrawn === 1 && benchMode !== null) runBench();
    }
    decoding = false;
    settleIdle();
  }

  function showOverlay(header) {
    const t = header.timings;
    const target = viewer.scene ? viewer.scene.passes : '?';
    $('overlay').textContent =
      `pass ${header.passes}/${target}  frame ${header.frame}  ${header.width}×${header.height} ${header.encoding}\n` +
      `epochs  lights ${header.epochs.lights}  camera ${header.epochs.camera}  settings ${header.epochs.settings}\n` +
      `ms  trace ${t.photon_trace_ms.toFixed(1)}  maps ${t.photon_map_build_ms.toFixed(1)}  ` +
      `render ${t.render_ms.toFixed(1)}  resolve ${(t.resolve_ms - t.encode_ms).toFixed(1)}  ` +
      `encode ${t.encode_ms.toFixed(1)}  queue ${t.queue_ms.toFixed(1)}`;
  }

  // --- pointer input ---
  let dragging = null;  // {kind: 'light', index, handle} or {kind: 'orbit', x, y}
  const imagePoint = (event) => {
    const rect = canvas.getBoundingClientRect();
    return { u: (event.clientX - rect.left) / rect.width, v: (event.clientY - rect.top) / rect.height, rect };
  };

  function nearestLight(event) {
    const { u, v, rect } = imagePoint(event);
    let best = null;
    for (const light of viewer.lights) {
      if (!light.draggable || !light.visible) continue;
      const at = handleAt(light);
      const distance = Math.hypot((at.u - u) * rect.width, (at.v - v) * rect.height);
      if (distance < 24 && (!best || distance < best.distance)) best = { light, distance };
    }
    return best && best.light;
  }

  canvas.addEventListener('contextmenu', (event) => event.preventDefault());
  canvas.addEventListener('pointerdown', (event) => {
    if (!viewer.scene) return;
    canvas.setPointerCapture(event.pointerId);
    const orbiting = event.button === 2 || event.shiftKey || event.altKey || event.ctrlKey;
    const light = orbiting ? null : nearestLight(event);
    if (light) {
      if (light.index !== viewer.selected) selectLight(light.index);
      const handle = $('handles').querySelector(`[data-index="${light.index}"]`);
      dragging = { kind: 'light', index: light.index, handle };
    } else if (orbiting) {
      dragging = { kind: 'orbit', x: event.clientX, y: event.clientY };
    }
  });
  canvas.addEventListener('pointermove', (event) => {
    if (!dragging) return;
    if (dragging.kind === 'light') {
      const { u, v } = imagePoint(event);
      dragLight(u, v);
    } else {
      const rect = canvas.getBoundingClientRect();
      const dx = (event.clientX - dragging.x) / rect.width;
      const dy = (event.clientY - dragging.y) / rect.height;
      dragging.x = event.clientX;
      dragging.y = event.clientY;
      change({ type: 'orbit', dx, dy });
    }
  });
  // A light drag's move to image position (u, v): what the pointer and the drag bench both call.
  function dragLight(u, v) {
    if (dragging.handle) placeHandle(dragging.handle, u, v);
    change({ type: 'move_light', light: dragging.index, u, v });
  }
  const endDrag = () => {
    dragging = null;
    if (!inFlight) showLights(viewer.lights);
  };
  canvas.addEventListener('pointerup', endDrag);
  canvas.addEventListener('pointercancel', endDrag);
  canvas.addEventListener('wheel', (event) => {
    if (!viewer.scene) return;
    event.preventDefault();
    change({ type: 'zoom', steps: -event.deltaY / 100 });
  }, { passive: false });

  // --- ?bench=drag&moves=N: moves the first draggable light N times as a drag does, one move at
  // a time, each after the previous move's frame was drawn and presented, and logs one
  // `caustica-drag-bench {...}` console line (scripts/viewer-latency reads it). ---
  let benchFailed = null;
  const median = (values) => {
    const sorted = values.filter(Number.isFinite).sort((a, b) => a - b);
    return sorted.length ? sorted[Math.floor(sorted.length / 2)] : null;
  };
  const round = (ms) => (ms === null ? null : Math.round(ms * 100) / 100);
  const benchError = (message) => {
    console.log(`caustica-drag-bench-error ${message}`);
    document.title = 'caustica-drag-bench error';
  };
  if (benchMode !== null) {
    if (benchMode !== 'drag') benchError(`bench=${benchMode}: the only bench is 'drag'`);
    else if (!Number.isInteger(benchMoves) || benchMoves < 1 || benchMoves > 10000) {
      benchError(`moves=${params.get('moves')}: give a whole number of moves from 1 to 10000`);
    } else if (!requestedScene) benchError('bench=drag needs scene=ID');
    else {
      setTimeout(() => {
        if (!viewer.framesDrawn) benchError(`no frame of scene ${requestedScene} within 120 s`);
      }, 120000);
    }
  }
  let benchStarted = false;
  async function runBench() {
    if (benchMode !== 'drag' || benchStarted || !Number.isInteger(benchMoves) || benchMoves < 1 ||
      benchMoves > 10000) return;
    benchStarted = true;
    const light = viewer.lights.find((l) => l.draggable);
    if (!light) {
      benchError(`scene ${viewer.scene.scene.id} has no light a drag can move`);
      return;
    }
    const nextFrame = () => new Promise((resolve) => requestAnimationFrame(() => resolve(performance.now())));
    const start = handleAt(light);
    const handle = $('handles').querySelector(`[data-index="${light.index}"]`);
    dragging = { kind: 'light', index: light.index, handle };
    const moves = [];
    try {
      for (let move = 0; move < benchMoves; ++move) {
        const measured = new Promise((resolve, reject) => {
          latencyListener = resolve;
          benchFailed = reject;
          setTimeout(() => reject(new Error(`move ${move + 1} showed no frame within 60 s`)), 60000);
        });
        // Small steps either side of where the handle was, as a slow drag makes.
        const offset = 0.01 * (1 + (move % 3)) * (move % 2 ? -1 : 1);
        dragLight(start.u + offset, start.v);
        const frame = await measured;
        const presentedAt = await nextFrame();
        moves.push({
          total_ms: frame.ms,
          to_arrival_ms: frame.arrivedAt - frame.sentAt,
          decode_ms: frame.decodedAt - frame.arrivedAt,
          draw_ms: frame.drawnAt - frame.decodedAt,
          present_ms: presentedAt - frame.drawnAt,
          bytes: frame.bytes,
          server: frame.header.timings,
          header: frame.header,
        });
      }
    } catch (error) {
      benchError(String(error.message || error));
      return;
    } finally {
      latencyListener = benchFailed = null;
      endDrag();
    }
    const of = (key) => moves.map((m) => m[key]);
    const server = {};
    for (const key of Object.keys(moves[0].server)) {
      server[key] = round(median(moves.map((m) => m.server[key])));
    }
    const last = moves[moves.length - 1].header;
    const result = {
      scene: viewer.scene.scene.id, moves: moves.length, width: last.width, height: last.height,
      encoding: last.encoding, bytes: median(of('bytes')),
      median_ms: round(median(of('total_ms'))), min_ms: round(Math.min(...of('total_ms'))),
      max_ms: round(Math.max(...of('total_ms'))),
      median_to_arrival_ms: round(median(of('to_arrival_ms'))), median_decode_ms: round(median(of('decode_ms'))),
      median_draw_ms: round(median(of('draw_ms'))), median_present_ms: round(median(of('present_ms'))),
      server_median_ms: server,
      total_ms: of('total_ms').map(round),
    };
    viewer.bench = result;
    console.log(`caustica-drag-bench ${JSON.stringify(result)}`);
    document.title = 'caustica-drag-bench done';
  }
})();
