// gyrowheel animate: the interactive page. Poses are computed in Python (animation/geometry.py,
// the model's own kinematics); this script only places the parts. World: x, y on the ground, z up.
const run = JSON.parse(document.getElementById("run").textContent);
const status = document.getElementById("status");
let rendered = 0;

function report(text) { status.textContent = text; }
window.addEventListener("error", (e) => report("error: " + e.message));
window.addEventListener("unhandledrejection", (e) => report("error: " + e.reason));

// three.js is embedded as text (vendored, offline): each module becomes a blob URL, and the
// module build's import of its core and OrbitControls' import of "three" are pointed at them.
async function loadThree() {
  const src = window.GYROWHEEL_THREE;
  const url = (text) => URL.createObjectURL(new Blob([text], { type: "text/javascript" }));
  const core = url(src.core);
  const three = url(src.module.split(src.coreSpecifier).join(JSON.stringify(core)));
  const orbit = url(src.orbit.split(src.threeSpecifier).join(JSON.stringify(three)));
  return [await import(three), (await import(orbit)).OrbitControls];
}

const [THREE, OrbitControls] = await loadThree();
const R = run.R, F = run.time.length;
const view = document.getElementById("view");
const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(window.devicePixelRatio);
renderer.setSize(view.clientWidth, view.clientHeight);
view.appendChild(renderer.domElement);

const scene = new THREE.Scene();
scene.background = new THREE.Color(0xffffff);
scene.add(new THREE.HemisphereLight(0xffffff, 0x8a8a70, 2.2));
const sun = new THREE.DirectionalLight(0xffffff, 1.5);
sun.position.set(3, -2, 6);
scene.add(sun);

const camera = new THREE.PerspectiveCamera(40, view.clientWidth / view.clientHeight, R / 10, 2000 * R);
camera.up.set(0, 0, 1);
const controls = new OrbitControls(camera, renderer.domElement);

// ground: a plane under the whole track and a grid of R/2 (coarser on long tracks)
const [x0, x1, y0, y1] = run.extent;
const side = Math.max(x1 - x0, y1 - y0) + 8 * R;
const ground = new THREE.Mesh(new THREE.PlaneGeometry(side, side),
  new THREE.MeshLambertMaterial({ color: 0xeef0e6 }));
ground.position.set((x0 + x1) / 2, (y0 + y1) / 2, 0);
scene.add(ground);
const divisions = Math.min(400, Math.ceil(side / (R / 2)));
const grid = new THREE.GridHelper(side, divisions, 0xc8ccbc, 0xc8ccbc);
grid.rotation.x = Math.PI / 2;
grid.position.set(ground.position.x, ground.position.y, 5e-3 * R);
scene.add(grid);

// the contact track, drawn up to the current time (the last `trail` seconds)
const trackGeometry = new THREE.BufferGeometry();
const T = run.track_time.length;
const trackXYZ = new Float32Array(3 * T);
for (let i = 0; i < T; i++) {
  trackXYZ[3 * i] = run.track[2 * i]; trackXYZ[3 * i + 1] = run.track[2 * i + 1]; trackXYZ[3 * i + 2] = 1e-2 * R;
}
trackGeometry.setAttribute("position", new THREE.BufferAttribute(trackXYZ, 3));
scene.add(new THREE.Line(trackGeometry, new THREE.LineBasicMaterial({ color: 0x555555 })));

// the wheel: body frame (e1, e2 in the wheel plane, turning with the spin; n the axle)
const wheel = new THREE.Group();
wheel.matrixAutoUpdate = false;
scene.add(wheel);
run.rim_colours.forEach((colour, j) => {
  const arc = new THREE.Mesh(new THREE.TorusGeometry(R, 0.04 * R, 8, 24, Math.PI / 2),
    new THREE.MeshBasicMaterial({ color: colour }));
  arc.rotation.z = j * Math.PI / 2;
  wheel.add(arc);
});
wheel.add(new THREE.Mesh(new THREE.CircleGeometry(R, 48), new THREE.MeshLambertMaterial(
  { color: 0x9aa3ad, transparent: true, opacity: 0.3, side: THREE.DoubleSide, depthWrite: false })));
const steel = new THREE.MeshLambertMaterial({ color: 0x4d4d4d });
for (let j = 0; j < 4; j++) {  // spokes from the hub to the rim quadrants' ends
  const spoke = new THREE.Mesh(new THREE.CylinderGeometry(0.012 * R, 0.012 * R, R, 6), steel);
  spoke.rotation.z = j * Math.PI / 2 - Math.PI / 2;
  spoke.position.set(0.5 * R * Math.cos(j * Math.PI / 2), 0.5 * R * Math.sin(j * Math.PI / 2), 0);
  wheel.add(spoke);
}
const axle = new THREE.Mesh(new THREE.CylinderGeometry(0.03 * R, 0.03 * R, 0.7 * R, 12),
  new THREE.MeshLambertMaterial({ color: 0x111111 }));
axle.rotation.x = Math.PI / 2;
wheel.add(axle);

// the Gyrover's flywheel (frame m_p, a x m_p, a) on its pendulum rod from the axle
let flywheel = null, rod = null;
if (run.fly) {
  flywheel = new THREE.Group();
  flywheel.matrixAutoUpdate = false;
  const disc = new THREE.Mesh(new THREE.CylinderGeometry(run.fly.radius, run.fly.radius, 0.15 * run.fly.radius, 32),
    new THREE.MeshLambertMaterial({ color: run.fly.colour }));
  disc.rotation.x = Math.PI / 2;
  flywheel.add(disc);
  const spin = new THREE.Mesh(new THREE.CylinderGeometry(0.015 * R, 0.015 * R, 0.8 * R, 8), steel);
  spin.rotation.x = Math.PI / 2;
  flywheel.add(spin);
  scene.add(flywheel);
  rod = new THREE.Line(new THREE.BufferGeometry().setFromPoints([new THREE.Vector3(), new THREE.Vector3()]),
    new THREE.LineBasicMaterial({ color: 0x4d4d4d }));
  scene.add(rod);
}
const heading = new THREE.ArrowHelper(new THREE.Vector3(1, 0, 0), new THREE.Vector3(), 1.4 * R, 0x6a3d9a,
  0.35 * R, 0.18 * R);
scene.add(heading);

function setPose(object, m, c, k) {  // m: 3x3 row-major per frame, c: 3 per frame
  const a = 9 * k, b = 3 * k;
  object.matrix.set(m[a], m[a + 1], m[a + 2], c[b], m[a + 3], m[a + 4], m[a + 5], c[b + 1],
    m[a + 6], m[a + 7], m[a + 8], c[b + 2], 0, 0, 0, 1);
  object.matrixWorldNeedsUpdate = true;
}

function firstAtOrAfter(times, t) {  // binary search in a sorted array
  let lo = 0, hi = times.length;
  while (lo < hi) { const mid = (lo + hi) >> 1; if (times[mid] < t) lo = mid + 1; else hi = mid; }
  return lo;
}

const readout = document.getElementById("readout");
const follow = document.getElementById("follow");
const lastCentre = new THREE.Vector3(run.centre[0], run.centre[1], run.centre[2]);

function show(k) {
  setPose(wheel, run.body, run.centre, k);
  if (flywheel) {
    setPose(flywheel, run.fly.frame, run.fly.centre, k);
    const p = rod.geometry.attributes.position;
    p.setXYZ(0, run.centre[3 * k], run.centre[3 * k + 1], run.centre[3 * k + 2]);
    p.setXYZ(1, run.fly.centre[3 * k], run.fly.centre[3 * k + 1], run.fly.centre[3 * k + 2]);
    p.needsUpdate = true;
  }
  const t = run.time[k];
  heading.position.set(run.contact[3 * k], run.contact[3 * k + 1], 1.5e-2 * R);
  heading.setDirection(new THREE.Vector3(run.heading[2 * k], run.heading[2 * k + 1], 0));
  const from = run.trail === null ? 0 : firstAtOrAfter(run.track_time, t - run.trail);
  const to = firstAtOrAfter(run.track_time, t + 1e-12);
  trackGeometry.setDrawRange(from, Math.max(0, to - from));
  const c = new THREE.Vector3(run.centre[3 * k], run.centre[3 * k + 1], run.centre[3 * k + 2]);
  if (follow.checked) {  // keep the user's view of the wheel: move camera and target with it
    const d = c.clone().sub(lastCentre);
    camera.position.add(d);
    controls.target.add(d);
  }
  lastCentre.copy(c);
  readout.textContent = run.readout[k] + "   ×" + speed.value;
}

// playback: simulated time advances by speed x wall-clock time; the frame shown is the last one due
const play = document.getElementById("play"), scrub = document.getElementById("scrub");
const speed = document.getElementById("speed");
for (const s of [0.25, 0.5, 1, 2, 4, 8, run.speed].filter((v, i, a) => a.indexOf(v) === i).sort((a, b) => a - b)) {
  speed.add(new Option("×" + s, s, false, s === run.speed));
}
scrub.max = F - 1;
let playing = true, k = 0, simTime = run.time[0], wall = null;
play.onclick = () => { playing = !playing; play.textContent = playing ? "pause" : "play"; wall = null; };
window.addEventListener("keydown", (e) => { if (e.code === "Space") { e.preventDefault(); play.onclick(); } });
scrub.oninput = () => { k = Number(scrub.value); simTime = run.time[k]; };
window.addEventListener("resize", () => {
  camera.aspect = view.clientWidth / view.clientHeight;
  camera.updateProjectionMatrix();
  renderer.setSize(view.clientWidth, view.clientHeight);
});

const [cx, cy, cz] = run.centre;
camera.position.set(cx + 2.6 * R, cy - 6.2 * R, cz + 3.2 * R);
controls.target.set(cx, cy, 0.6 * R);
controls.update();

function frame(now) {
  if (playing && wall !== null) {
    simTime += (now - wall) / 1000 * Number(speed.value);
    if (simTime > run.time[F - 1]) simTime = run.time[0];  // loop
    k = Math.max(0, firstAtOrAfter(run.time, simTime + 1e-12) - 1);
    scrub.value = k;
  }
  wall = now;
  show(k);
  controls.update();
  renderer.render(scene, camera);
  rendered += 1;
  status.dataset.rendered = rendered;
  status.dataset.frame = k;
  report(`three.js r${THREE.REVISION}: rendered frame ${rendered}, showing ${k + 1}/${F}`);
  requestAnimationFrame(frame);
}
requestAnimationFrame(frame);
