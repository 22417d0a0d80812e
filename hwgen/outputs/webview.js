// view.html's viewer: draws the assembly the page holds (a GLB, base64, in #hwgen-glb) with what
// hwgen worked out for it (JSON in #hwgen-data: every part's exploded offset and bent placement,
// the tendons' eyelet points in each pose, the checks naming each part). It works nothing out
// again: the poses are hwgen.outputs.scene's. `make viewer` bundles it with three.js (npm) into
// one script that hwgen/outputs/webview.py inlines; the bundle is never committed.
import * as THREE from "three";
import { OrbitControls } from "three/addons/controls/OrbitControls.js";
import { GLTFLoader } from "three/addons/loaders/GLTFLoader.js";
import { CSS2DObject, CSS2DRenderer } from "three/addons/renderers/CSS2DRenderer.js";

const SELECTED = new THREE.Color(0x1a4f9c);   // the emissive tint of what is clicked
const CLICK_PX = 4;                           // a press that moves further is a drag, not a click

function say(text) {
  const li = document.createElement("li");
  li.textContent = text;
  document.getElementById("messages").appendChild(li);
}

function bytes(b64) {
  const s = atob(b64.trim());
  const out = new Uint8Array(s.length);
  for (let i = 0; i < s.length; i++) out[i] = s.charCodeAt(i);
  return out;
}

function escapeHtml(text) {
  const d = document.createElement("div");
  d.textContent = text;
  return d.innerHTML;
}

class Viewer {
  constructor(data, container) {
    this.data = data;
    this.container = container;
    this.renderer = new THREE.WebGLRenderer({ antialias: true });
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    this.renderer.setClearColor(0xffffff);
    container.appendChild(this.renderer.domElement);
    this.labels = new CSS2DRenderer();        // the failing checks' ids beside their parts and tendons
    this.labels.domElement.id = "labels";
    container.appendChild(this.labels.domElement);
    this.scene = new THREE.Scene();
    this.camera = new THREE.PerspectiveCamera(30, 1, 1, 10000);
    this.camera.up.set(...data.view.up);
    this.scene.add(this.camera);
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x606060, 2.0));
    const key = new THREE.DirectionalLight(0xffffff, 1.6);
    key.position.set(0.4, 0.6, 1.0);
    this.camera.add(key);                     // the light comes from the viewer, whichever way it turns
    this.controls = new OrbitControls(this.camera, this.renderer.domElement);
    this.controls.addEventListener("change", () => this.draw());
    this.parts = new Map();                   // name -> {info, object, meshes, base, bent: {pose: Mesh}}
    this.tendons = new Map();                 // name -> {info, mesh, material}
    this.pose = "straight";
    this.explode = 0;
    this.marks = true;
    this.selected = null;
    this.pending = false;
    this.loaded = false;
    // the info panel as the page came (the failing checks), shown again when nothing is selected
    this.before = ["info-title", "info-body"].map((id) => document.getElementById(id).innerHTML);
    new ResizeObserver(() => this.resize()).observe(container);
  }

  load(glb) {
    return new Promise((resolve, reject) => {
      new GLTFLoader().parse(glb.buffer, "", (gltf) => { this.place(gltf.scene); resolve(); }, reject);
    });
  }

  place(root) {
    this.scene.add(root);
    root.updateMatrixWorld(true);
    const byName = new Map();
    root.traverse((o) => { if (o.userData.name) byName.set(o.userData.name, o); });
    for (const info of this.data.parts) {
      const object = byName.get(info.name);
      if (!object) { say(`${info.name}: not in the page's GLB`); continue; }
      const meshes = [];
      object.traverse((o) => { if (o.isMesh) meshes.push(o); });
      const material = new THREE.MeshStandardMaterial({
        color: new THREE.Color(info.colour), roughness: 0.7, metalness: 0.0, flatShading: true });
      for (const m of meshes) { m.material = material; m.userData.part = info.name; }
      object.updateMatrix();
      object.matrixAutoUpdate = false;        // placed by apply(): the manifest's placement, moved by a pose
      const part = { info, object, meshes, material, base: object.matrix.clone(), bent: {} };
      this.parts.set(info.name, part);
      const faces = this.data.bending[info.name];
      for (const pose of this.data.poses) {
        if (!faces) break;                    // a rigid part: the pose's matrix moves it
        const g = new THREE.BufferGeometry();
        g.setAttribute("position", new THREE.BufferAttribute(new Float32Array(bytes(pose.vertices[info.name]).buffer), 3));
        g.setIndex(new THREE.BufferAttribute(new Uint32Array(bytes(faces).buffer), 1));
        const bent = new THREE.Mesh(g, material);
        bent.visible = false;
        bent.userData.part = info.name;
        this.scene.add(bent);
        part.bent[pose.key] = bent;
        part.meshes.push(bent);
      }
    }
    for (const info of this.data.tendons) {
      const material = new THREE.MeshStandardMaterial({ color: new THREE.Color(info.colour), roughness: 0.5 });
      const mesh = new THREE.Mesh(new THREE.BufferGeometry(), material);
      mesh.userData.tendon = info.name;
      this.scene.add(mesh);
      this.tendons.set(info.name, { info, mesh, material });
    }
    this.marked = this.markLabels();
    this.loaded = true;
    this.apply();
    this.fit();
  }

  // every part and tendon where the pose and the explode slider put it, in its colour
  apply() {
    const straight = this.pose === "straight";
    const pose = this.data.poses.find((p) => p.key === this.pose);
    const shift = new THREE.Vector3();
    for (const part of this.parts.values()) {
      const shown = this.visible(part.info.name);
      const bent = straight ? null : part.bent[this.pose];
      part.object.visible = shown && !bent && (straight || !part.info.fixture);
      for (const [key, mesh] of Object.entries(part.bent)) mesh.visible = shown && key === this.pose;
      if (straight) {
        shift.fromArray(part.info.shift).multiplyScalar(this.explode);
        part.object.matrix.copy(part.base).premultiply(new THREE.Matrix4().makeTranslation(shift));
      } else if (pose.matrices[part.info.name]) {
        part.object.matrix.fromArray(pose.matrices[part.info.name]);
      }
      part.object.matrixWorldNeedsUpdate = true;
      const failing = this.marks && part.info.failing.length > 0;
      part.material.color.set(failing ? this.data.warning_colour : part.info.colour);
      part.material.emissive.set(this.selected === part.info.name ? SELECTED : 0x000000);
    }
    for (const t of this.tendons.values()) {
      const pts = straight
        ? t.info.straight.map((p, i) => new THREE.Vector3(...p).addScaledVector(
            new THREE.Vector3(...t.info.shift[i]), this.explode))
        : t.info[this.pose].map((p) => new THREE.Vector3(...p));
      const path = new THREE.CurvePath();
      for (let i = 1; i < pts.length; i++) path.add(new THREE.LineCurve3(pts[i - 1], pts[i]));
      t.mesh.geometry.dispose();
      t.mesh.geometry = new THREE.TubeGeometry(path, 8 * pts.length, this.data.tendon_radius_mm, 8, false);
      t.mesh.visible = this.visible(t.info.name, true);
      t.material.color.set(this.marks && t.info.failing.length ? this.data.warning_colour : t.info.colour);
      t.material.emissive.set(this.selected === t.info.name ? SELECTED : 0x000000);
    }
    this.placeLabels();
    this.draw();
  }

  // a label per set of failing check ids: the parts that fail the same checks share one, each
  // failing tendon has its own (its name first)
  markLabels() {
    const groups = new Map();
    for (const p of this.parts.values()) {
      if (!p.info.failing.length) continue;
      const text = p.info.failing.join(", ");
      if (!groups.has(text)) groups.set(text, { text, parts: [], tendon: null });
      groups.get(text).parts.push(p);
    }
    const out = [...groups.values()];
    for (const t of this.tendons.values()) {
      if (t.info.failing.length) out.push({ text: `${t.info.name}: ${t.info.failing.join(", ")}`, parts: [], tendon: t });
    }
    for (const m of out) {
      const div = document.createElement("div");
      div.className = "label";
      div.textContent = m.text;
      m.object = new CSS2DObject(div);
      m.object.center.set(-0.05, 0.5);       // just right of the point
      this.scene.add(m.object);
    }
    return out;
  }

  placeLabels() {
    this.scene.updateMatrixWorld(true);
    const failingTendons = this.marked.filter((m) => m.tendon);
    for (const m of this.marked) {
      const box = new THREE.Box3();
      for (const p of m.parts) for (const mesh of p.meshes) if (this.shown(mesh)) box.expandByObject(mesh);
      if (m.tendon && m.tendon.mesh.visible) {
        const pts = m.tendon.mesh.geometry.parameters.path.curves.map((c) => c.v2);
        const k = failingTendons.indexOf(m);            // spread along the tendons, so two do not meet
        box.expandByPoint(pts[Math.min(pts.length - 1, Math.floor(pts.length * (k + 1) / (failingTendons.length + 1)))]);
      }
      m.object.visible = this.marks && !box.isEmpty();
      // beside the parts, half way along them; near the base for the strip (the tendons' labels are along it)
      const along = m.parts.some((p) => this.data.bending[p.info.name]) ? 0.1 : 0.5;
      if (!box.isEmpty()) m.object.position.set(box.max.x, box.min.y + along * (box.max.y - box.min.y), box.max.z);
    }
  }

  visible(name, tendon = false) {
    const box = document.querySelector(`input[data-${tendon ? "tendon" : "part"}="${CSS.escape(name)}"]`);
    return box ? box.checked : true;
  }

  // the camera on the page's view direction, as near as it can be with every shown part in frame
  // (the corners of each part's own box, so a long robot seen askew is not framed by its world box)
  fit() {
    this.scene.updateMatrixWorld(true);
    const corners = [];
    for (const part of this.parts.values()) {
      for (const m of part.meshes) {
        if (!this.shown(m)) continue;
        if (!m.geometry.boundingBox) m.geometry.computeBoundingBox();
        const b = m.geometry.boundingBox;
        for (let i = 0; i < 8; i++) {
          corners.push(new THREE.Vector3(i & 1 ? b.max.x : b.min.x, i & 2 ? b.max.y : b.min.y,
                                         i & 4 ? b.max.z : b.min.z).applyMatrix4(m.matrixWorld));
        }
      }
    }
    if (!corners.length) return;
    const toward = new THREE.Vector3(...this.data.view.toward_camera).normalize();
    const centre = new THREE.Box3().setFromPoints(corners).getCenter(new THREE.Vector3());
    this.camera.position.copy(centre);
    this.camera.lookAt(centre.clone().sub(toward));
    this.camera.updateMatrixWorld(true);
    const seen = corners.map((c) => c.clone().applyMatrix4(this.camera.matrixWorldInverse));
    const box = new THREE.Box3().setFromPoints(seen);        // as the camera sees them, from the centre
    const mid = box.getCenter(new THREE.Vector3());
    centre.add(new THREE.Vector3(mid.x, mid.y, 0).transformDirection(this.camera.matrixWorld).multiplyScalar(
      Math.hypot(mid.x, mid.y)));
    const tanV = Math.tan(THREE.MathUtils.degToRad(this.camera.fov / 2)), tanH = tanV * this.camera.aspect;
    let distance = 0;
    for (const c of seen) {
      distance = Math.max(distance, c.z + Math.abs(c.x - mid.x) / tanH, c.z + Math.abs(c.y - mid.y) / tanV);
    }
    distance *= 1.03;
    this.camera.position.copy(centre).addScaledVector(toward, distance);
    this.camera.near = distance / 100;
    this.camera.far = distance * 10;
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(centre);
    this.controls.update();
    this.draw();
  }

  resize() {
    const w = this.container.clientWidth, h = this.container.clientHeight;
    if (!w || !h) return;
    this.renderer.setSize(w, h, false);
    this.labels.setSize(w, h);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    this.draw();
  }

  draw() {
    if (this.pending) return;
    this.pending = true;
    requestAnimationFrame(() => {
      this.pending = false;
      this.renderer.render(this.scene, this.camera);
      this.labels.render(this.scene, this.camera);
      if (this.loaded) document.body.dataset.state = "ready";
    });
  }

  pickables() {
    const out = [];
    for (const p of this.parts.values()) for (const m of p.meshes) if (this.shown(m)) out.push(m);
    for (const t of this.tendons.values()) if (t.mesh.visible) out.push(t.mesh);
    return out;
  }

  // what is under a point of the canvas (client coordinates): a part's or a tendon's name, or null
  hit(x, y) {
    const r = this.renderer.domElement.getBoundingClientRect();
    const ndc = new THREE.Vector2(((x - r.left) / r.width) * 2 - 1, -((y - r.top) / r.height) * 2 + 1);
    const ray = new THREE.Raycaster();
    ray.setFromCamera(ndc, this.camera);
    this.scene.updateMatrixWorld(true);
    const hits = ray.intersectObjects(this.pickables(), false);
    if (!hits.length) return null;
    return hits[0].object.userData.part || hits[0].object.userData.tendon || null;
  }

  shown(o) {
    for (let p = o; p; p = p.parent) if (!p.visible) return false;
    return true;
  }

  // a point of the canvas (client coordinates) where a click lands on this part: the centre of one
  // of its triangles that nothing hides (for tests, and the tree's "show me")
  pointOn(name) {
    const part = this.parts.get(name);
    if (!part) return null;
    const r = this.renderer.domElement.getBoundingClientRect();
    this.scene.updateMatrixWorld(true);
    for (const mesh of part.meshes) {
      if (!this.shown(mesh)) continue;
      const pos = mesh.geometry.getAttribute("position"), index = mesh.geometry.getIndex();
      const n = index ? index.count / 3 : pos.count / 3;
      const step = Math.max(1, Math.floor(n / 400));
      const a = new THREE.Vector3(), b = new THREE.Vector3(), c = new THREE.Vector3();
      for (let f = 0; f < n; f += step) {
        const i = index ? [index.getX(3 * f), index.getX(3 * f + 1), index.getX(3 * f + 2)] : [3 * f, 3 * f + 1, 3 * f + 2];
        a.fromBufferAttribute(pos, i[0]); b.fromBufferAttribute(pos, i[1]); c.fromBufferAttribute(pos, i[2]);
        const p = a.add(b).add(c).divideScalar(3).applyMatrix4(mesh.matrixWorld).project(this.camera);
        if (Math.abs(p.x) > 0.98 || Math.abs(p.y) > 0.98 || p.z > 1) continue;
        const x = r.left + (p.x + 1) / 2 * r.width, y = r.top + (1 - p.y) / 2 * r.height;
        if (this.hit(x, y) === name) return { x, y };
      }
    }
    return null;
  }

  select(name) {
    this.selected = name;
    document.querySelectorAll("nav#tree li").forEach((li) =>
      li.classList.toggle("selected", li.dataset.part === name || li.dataset.tendon === name));
    const info = (this.parts.get(name) || this.tendons.get(name) || {}).info;
    const title = document.getElementById("info-title"), body = document.getElementById("info-body");
    if (!info) { [title.innerHTML, body.innerHTML] = this.before; this.apply(); return; }
    const checks = info.checks.map((i) => this.data.checks[i]);
    const order = { FAIL: 0, warning: 1, info: 2, pass: 3 };
    checks.sort((a, b) => order[a.status] - order[b.status]);
    const failed = checks.filter((c) => c.status === "FAIL").length;
    title.textContent = `${name}: ${checks.length} checks, ${failed} failed`;
    body.innerHTML = `<p class=note>${escapeHtml(info.family || "tendon")}${info.station != null ? ", station " + info.station : ""}`
      + `${info.box ? ", drawn as its box" : ""}</p>`
      + checks.map((c) => `<div class="check ${c.status}"><span class=status>${escapeHtml(c.status)}</span>`
        + `<b>${escapeHtml(c.id)}</b> <span class=where>${escapeHtml(c.where)}</span><div>${escapeHtml(c.message)}</div>`
        + (c.fix ? `<div class=fix>fix: ${escapeHtml(c.fix)}</div>` : "") + "</div>").join("");
    this.apply();
  }
}

function wire(viewer) {
  const tree = document.getElementById("tree");
  tree.addEventListener("change", (e) => {
    const box = e.target;
    if (box.dataset.group) {
      box.closest("details").querySelectorAll("ul input[type=checkbox]").forEach((b) => { b.checked = box.checked; });
    }
    viewer.apply();
  });
  tree.addEventListener("click", (e) => {
    if (!e.target.matches("button.name")) return;
    const li = e.target.closest("li");
    viewer.select(li.dataset.part || li.dataset.tendon);
  });
  const explode = document.getElementById("explode"), mm = document.getElementById("explode-mm");
  explode.addEventListener("input", () => {
    viewer.explode = Number(explode.value);
    mm.textContent = `${(viewer.explode * viewer.data.explode_mm).toFixed(0)} mm`;
    viewer.apply();
  });
  explode.addEventListener("change", () => viewer.fit());
  document.getElementById("pose").addEventListener("change", (e) => {
    viewer.pose = e.target.value;
    explode.disabled = viewer.pose !== "straight";
    viewer.apply();
    viewer.fit();
  });
  document.getElementById("marks").addEventListener("change", (e) => { viewer.marks = e.target.checked; viewer.apply(); });
  document.getElementById("fit").addEventListener("click", () => viewer.fit());
  const canvas = viewer.renderer.domElement;
  let down = null;
  canvas.addEventListener("pointerdown", (e) => { down = [e.clientX, e.clientY]; });
  canvas.addEventListener("pointerup", (e) => {
    if (!down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > CLICK_PX) return;
    viewer.select(viewer.hit(e.clientX, e.clientY));
  });
}

async function main() {
  const data = JSON.parse(document.getElementById("hwgen-data").textContent);
  let viewer;
  try {
    viewer = new Viewer(data, document.getElementById("canvas"));
  } catch (e) {
    document.body.dataset.state = "no-webgl";
    say(`The 3D view needs WebGL, which this browser did not give (${e.message}); the parts and checks are listed.`);
    return;
  }
  viewer.resize();
  await viewer.load(bytes(document.getElementById("hwgen-glb").textContent));
  wire(viewer);
  window.hwgenView = { parts: [...viewer.parts.keys()], pointOn: (n) => viewer.pointOn(n),
                       select: (n) => viewer.select(n), revision: THREE.REVISION };
}

window.addEventListener("error", (e) => say(`The viewer stopped: ${e.message}`));
main().catch((e) => { document.body.dataset.state = "failed"; say(`The viewer stopped: ${e.message || e}`); });
