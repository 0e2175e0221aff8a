// real2code view: the object's glTF (written by real2code_export) with a slider per joint.
//
// The joint facts come from the file's own extras (the "real2code" key on each joint node:
// type, axis in the child frame, limits, observed state); a slider sets the child part
// node's local rotation (about the axis) or translation (along it), exactly as the glTF
// writer poses it, so the page shows the model's forward kinematics. Query parameters:
//   pose=<joint>:<value>,...   set sliders at load (radians or metres), through the sliders
//   panel=0                    hide the panel (screenshots of the object alone)
//   view=<azimuth>,<elevation> camera direction in degrees: azimuth from the object's +x
//                              towards +y, elevation above its xy plane (default -30,25)
//   axes=0                     joint axes hidden at load
//   report=1                   POST the state to the server whenever it changes (headless)
// The page writes its state (each part's matrix and the camera, in the object's frame) into
// the JSON script element #state, for tests and for scripts that drive the page.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

const KEY = 'real2code';
const BACKGROUND = 0xffffff;
const params = new URLSearchParams(location.search);
const REPORT = params.get('report') === '1';

const canvas = document.getElementById('view');
const renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
renderer.setPixelRatio(1);
const scene = new THREE.Scene();
scene.background = new THREE.Color(BACKGROUND);
const camera = new THREE.PerspectiveCamera(40, 1, 0.01, 100);
scene.add(camera);
scene.add(new THREE.HemisphereLight(0xffffff, 0x888888, 1.6));
const headlight = new THREE.DirectionalLight(0xffffff, 1.4);
headlight.position.set(0.3, 0.6, 1.0);
camera.add(headlight);
const controls = new OrbitControls(camera, canvas);
controls.addEventListener('change', render);

let objectNode = null; // the glTF node of the object: its frame is the model's
const joints = []; // {name, type, axis, child, slider, arrow}

function render() {
  renderer.render(scene, camera);
  writeState();
}

function resize() {
  const w = canvas.clientWidth, h = canvas.clientHeight;
  renderer.setSize(w, h, false);
  camera.aspect = w / h;
  camera.updateProjectionMatrix();
  render();
}

function setJoint(joint, value) {
  if (joint.type === 'prismatic') {
    joint.child.position.copy(joint.axis).multiplyScalar(value);
  } else {
    joint.child.quaternion.setFromAxisAngle(joint.axis, value);
  }
  joint.output.value = joint.type === 'prismatic'
    ? `${(value * 1000).toFixed(0)} mm` : `${THREE.MathUtils.radToDeg(value).toFixed(1)}°`;
}

function addSlider(form, joint, facts) {
  const limits = facts.limits;
  const lower = limits ? limits.lower : -Math.PI;
  const upper = limits ? limits.upper : Math.PI;
  const row = document.createElement('div');
  row.className = 'joint';
  const label = document.createElement('label');
  label.textContent = `${joint.name} (${joint.type})`;
  const output = document.createElement('output');
  const slider = document.createElement('input');
  Object.assign(slider, { type: 'range', name: joint.name, min: lower, max: upper,
                          step: 'any', value: facts.state ?? 0 });
  slider.setAttribute('aria-label', joint.name);
  label.htmlFor = slider.id = `joint-${joints.length}`;
  slider.addEventListener('input', () => { setJoint(joint, Number(slider.value)); render(); });
  row.append(label, output, slider);
  form.append(row);
  Object.assign(joint, { slider, output });
}

function axisArrow(joint, size) {
  // drawn in the joint node's frame (the joint origin), where the axis is expressed
  const color = joint.type === 'prismatic' ? 0x1f77b4 : 0xd62728;
  const arrow = new THREE.ArrowHelper(joint.axis, new THREE.Vector3(), size, color,
                                     0.2 * size, 0.1 * size);
  arrow.name = `${joint.name} axis`;
  arrow.traverse((o) => { if (o.material) o.material.depthTest = false; }); // seen through parts
  arrow.renderOrder = 1;
  arrow.userData.isAxis = true;
  return arrow;
}

function writeState() {
  if (!objectNode) return;
  scene.updateMatrixWorld(true);
  const toObject = objectNode.matrixWorld.clone().invert();
  const parts = {};
  objectNode.traverse((node) => {
    const facts = node.userData[KEY];
    if (facts && facts.part !== undefined) {
      parts[facts.part] = toObject.clone().multiply(node.matrixWorld).toArray();
    }
  });
  const state = {
    object: objectNode.userData[KEY]?.object,
    joints: Object.fromEntries(joints.map((j) => [j.name, Number(j.slider.value)])),
    parts,
    camera: { matrix: toObject.clone().multiply(camera.matrixWorld).toArray(),
              fov: camera.fov, aspect: camera.aspect,
              width: canvas.width, height: canvas.height },
    background: BACKGROUND,
  };
  const text = JSON.stringify(state);
  document.getElementById('state').textContent = text;
  // headless runs: every change goes back to the server, so its last state is what the
  // screenshot shows (the window may still be resized after the first frame)
  if (REPORT && document.body.dataset.ready === 'true') report(text);
}

function report(text) {
  return fetch('state', { method: 'POST', body: text });
}

function frameCamera() {
  const box = new THREE.Box3().setFromObject(objectNode, true);
  const center = box.getCenter(new THREE.Vector3());
  const radius = box.getSize(new THREE.Vector3()).length() / 2;
  // azimuth from the object's +x towards its +y, elevation above its xy plane (Z up: the
  // object node turns the model's frame into three.js's Y-up world)
  const [az, el] = (params.get('view') ?? '-30,25').split(',').map(Number);
  const [a, e] = [THREE.MathUtils.degToRad(az), THREE.MathUtils.degToRad(el)];
  const dir = new THREE.Vector3(Math.cos(e) * Math.cos(a), Math.cos(e) * Math.sin(a), Math.sin(e))
    .transformDirection(objectNode.matrixWorld);
  const distance = radius / Math.sin(THREE.MathUtils.degToRad(camera.fov / 2)) * 1.1;
  camera.position.copy(center).addScaledVector(dir, distance);
  camera.near = distance / 100;
  camera.far = distance * 10;
  camera.lookAt(center);
  controls.target.copy(center);
  controls.update();
  return radius;
}

function applyPoseParameter() {
  const text = params.get('pose');
  if (!text) return;
  for (const item of text.split(',')) {
    const [name, value] = item.split(':');
    const joint = joints.find((j) => j.name === name);
    if (!joint || value === undefined || Number.isNaN(Number(value))) {
      throw new Error(`pose: no joint ${JSON.stringify(name)} or no number in ${JSON.stringify(item)}`);
    }
    joint.slider.value = value; // as a user moving the slider: the same event
    joint.slider.dispatchEvent(new Event('input'));
  }
}

async function main() {
  if (params.get('panel') === '0') document.getElementById('panel').classList.add('hidden');
  const gltf = await new GLTFLoader().loadAsync('model.glb');
  objectNode = gltf.scene.children.find((n) => n.userData[KEY]?.object !== undefined)
    ?? gltf.scene;
  scene.add(gltf.scene);
  document.getElementById('title').textContent = objectNode.userData[KEY]?.object ?? 'object';
  const form = document.getElementById('joints');
  const jointNodes = [];
  gltf.scene.traverse((node) => {
    const facts = node.userData[KEY];
    if (facts && facts.joint !== undefined && facts.type !== 'fixed' && facts.axis) {
      jointNodes.push([node, facts]);
    }
  });
  scene.updateMatrixWorld(true);
  const radius = frameCamera();
  for (const [node, facts] of jointNodes) {
    const child = node.children.find((c) => c.userData[KEY]?.part === facts.child);
    if (!child) continue;
    const joint = { name: facts.joint, type: facts.type, child,
                    axis: new THREE.Vector3(...facts.axis).normalize() };
    addSlider(form, joint, facts);
    joint.arrow = axisArrow(joint, 0.3 * radius);
    node.add(joint.arrow);
    setJoint(joint, Number(joint.slider.value));
    joints.push(joint);
  }
  document.getElementById('axes').addEventListener('change', (e) => {
    for (const j of joints) j.arrow.visible = e.target.checked;
    render();
  });
  if (params.get('axes') === '0') {
    document.getElementById('axes').checked = false;
    for (const j of joints) j.arrow.visible = false;
  }
  applyPoseParameter();
  window.addEventListener('resize', resize);
  resize();
  document.body.dataset.ready = 'true';
  if (REPORT) await report(document.getElementById('state').textContent);
}

main().catch((error) => {
  document.getElementById('message').textContent = String(error);
  document.body.dataset.ready = 'error';
  console.error(error);
  if (REPORT) report(JSON.stringify({ error: String(error) }));
});
