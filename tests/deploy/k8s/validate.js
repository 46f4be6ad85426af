// Validates Kubernetes manifests against the API's schemas, twice over:
//  1. kubernetes-models' validators: JSON schemas generated from the official OpenAPI
//     definitions (types, formats, enums, required fields), compiled with ajv;
//  2. the same package's TypeScript types, generated from the same definitions, through
//     tsc --strict: an object literal with a field the API does not have is an error
//     (what kubeconform -strict reports; the JSON schemas allow unknown fields).
// Then the project's own rules for deploy/k8s (threads match CPUs, probes, volumes).
//
//   node validate.js FILE.yaml...     exit 0 when every document passes, 1 otherwise
// Run it in the folder where its package.json's dependencies are installed (npm ci).
"use strict";
const fs = require("fs");
const path = require("path");
const { execFileSync } = require("child_process");
const YAML = require("yaml");

const errors = [];
const err = (where, msg) => errors.push(`${where}: ${msg}`);
const docs = [];

for (const file of process.argv.slice(2)) {
  const parsed = YAML.parseAllDocuments(fs.readFileSync(file, "utf8"));
  parsed.forEach((d, i) => {
    const where = `${path.basename(file)}#${i}`;
    if (d.errors.length) return err(where, `YAML: ${d.errors[0].message}`);
    const obj = d.toJS();
    if (obj === null) return;
    docs.push({ where, obj, file });
  });
}

// apiVersion "apps/v1" -> kubernetes-models/apps/v1/Kind, "v1" -> kubernetes-models/v1/Kind
function modelPath(obj) {
  if (typeof obj.apiVersion !== "string" || typeof obj.kind !== "string") return null;
  return `kubernetes-models/${obj.apiVersion}/${obj.kind}`;
}

const ts = [];
docs.forEach((d, i) => {
  const { where, obj } = d;
  if (obj.kind === "Kustomization") {
    for (const r of obj.resources || [])
      if (!fs.existsSync(path.join(path.dirname(d.file), r))) err(where, `resource ${r} does not exist`);
    return;
  }
  const mp = modelPath(obj);
  let Model;
  try {
    Model = mp && require(mp)[obj.kind];
  } catch (e) {
    Model = null;
  }
  if (!Model) return err(where, `unknown apiVersion/kind ${obj.apiVersion}/${obj.kind}`);
  try {
    new Model(obj).validate();
  } catch (e) {
    err(`${where} ${obj.kind}/${obj.metadata && obj.metadata.name}`, `schema: ${e.message}`);
  }
  ts.push(`// ${where}\nimport { I${obj.kind} as T${i} } from "${mp}";`);
  ts.push(`export const d${i}: T${i} = ${JSON.stringify(obj, null, 2)};`);
});

// 2. unknown fields, through the generated types.
if (ts.length) {
  // Beside node_modules, so that tsc resolves the packages from there.
  const dir = fs.mkdtempSync(path.join(process.cwd(), ".check-"));
  const src = path.join(dir, "manifests.ts");
  fs.writeFileSync(src, ts.join("\n") + "\n");
  const tsc = require.resolve("typescript/bin/tsc");
  try {
    execFileSync(process.execPath, [tsc, "--noEmit", "--strict", "--skipLibCheck", "--moduleResolution", "node",
      "--module", "commonjs", "--target", "es2020", src],
      { encoding: "utf8" });
  } catch (e) {
    const out = (e.stdout || "") + (e.stderr || "");
    // Name the manifest for every error: the generated file says which document is where.
    const lines = fs.readFileSync(src, "utf8").split("\n");
    for (const m of out.matchAll(/manifests\.ts\((\d+),\d+\): (error .*)/g)) {
      let n = Number(m[1]) - 1, where = "?";
      while (n >= 0 && !lines[n].startsWith("// ")) n--;
      if (n >= 0) where = lines[n].slice(3);
      err(where, `type: ${m[2]}`);
    }
    if (!/manifests\.ts\(/.test(out)) err("tsc", out.trim() || String(e));
  }
  fs.rmSync(dir, { recursive: true, force: true });
}

// 3. deploy/k8s's own rules.
const byKind = (k) => docs.filter((d) => d.obj.kind === k);
const containers = (d) => (d.obj.spec.template.spec.containers || []);
function cpuCores(q) {
  if (typeof q === "number") return q;
  if (typeof q !== "string") return NaN;
  return q.endsWith("m") ? Number(q.slice(0, -1)) / 1000 : Number(q);
}
for (const d of byKind("Deployment").concat(byKind("StatefulSet"))) {
  const tpl = d.obj.spec.template;
  const sel = d.obj.spec.selector.matchLabels || {};
  for (const [k, v] of Object.entries(sel))
    if (tpl.metadata.labels[k] !== v) err(d.where, `selector ${k}=${v} does not match the pod template`);
  const volumes = new Set((tpl.spec.volumes || []).map((v) => v.name));
  for (const t of d.obj.spec.volumeClaimTemplates || []) volumes.add(t.metadata.name);
  for (const c of (tpl.spec.initContainers || []).concat(containers(d)))
    for (const m of c.volumeMounts || [])
      if (!volumes.has(m.name)) err(d.where, `container ${c.name} mounts unknown volume ${m.name}`);
  for (const c of containers(d)) {
    const args = c.args || [];
    if (args[0] === "worker") {
      const t = args.find((a) => a.startsWith("--threads="));
      const threads = t ? Number(t.slice(10)) : NaN;
      const req = cpuCores(c.resources && c.resources.requests && c.resources.requests.cpu);
      const lim = cpuCores(c.resources && c.resources.limits && c.resources.limits.cpu);
      if (!(threads >= 1) || threads !== req || threads !== lim)
        err(d.where, `worker --threads=${threads} must equal requests.cpu (${req}) and limits.cpu (${lim})`);
    }
    if (args[0] === "coordinator") {
      if (d.obj.kind !== "StatefulSet") err(d.where, "the coordinator must be a StatefulSet");
      if (!c.readinessProbe) err(d.where, "the coordinator has no readiness probe");
      if (!(d.obj.spec.volumeClaimTemplates || []).length) err(d.where, "the coordinator has no volume claim");
      const state = args.find((a) => a.startsWith("--state="));
      if (!state || !(c.volumeMounts || []).some((m) => m.mountPath === state.slice(8)))
        err(d.where, "the coordinator's --state is not a mounted volume");
    }
  }
}
for (const s of byKind("Service")) {
  const pods = byKind("StatefulSet").concat(byKind("Deployment")).filter((d) =>
    Object.entries(s.obj.spec.selector || {}).every(([k, v]) => d.obj.spec.template.metadata.labels[k] === v));
  if (pods.length !== 1) err(s.where, `selects ${pods.length} workloads, expected 1`);
}

if (errors.length) {
  for (const e of errors) console.log(`INVALID ${e}`);
  process.exit(1);
}
for (const d of docs) console.log(`valid   ${d.where} ${d.obj.kind}/${(d.obj.metadata || {}).name || ""}`);
