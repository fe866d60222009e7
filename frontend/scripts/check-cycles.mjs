// Import cycles among the editor's modules: exit 1 naming each cycle, 0 when there is none.
// `node scripts/check-cycles.mjs [dir …]` (default: node_editor). Every relative import counts, type-only
// ones and re-exports too: a cycle of types is still two modules that cannot be read one without the
// other. Modules shared by two that need each other's parts belong in a third that both import.
// Imports are read with TypeScript's own pre-processor (no type checking), so this runs in a second.
import { existsSync, readdirSync, readFileSync, statSync } from "node:fs";
import { dirname, join, relative, resolve } from "node:path";
import ts from "typescript";

const root = resolve(new URL("..", import.meta.url).pathname);
const dirs = process.argv.slice(2).length ? process.argv.slice(2) : ["node_editor"];
const SOURCE = /\.(ts|tsx|mts|js|jsx|mjs)$/;
const CANDIDATES = ["", ".ts", ".tsx", ".mts", ".js", ".jsx", ".mjs", "/index.ts", "/index.tsx", "/index.js"];

function sources(dir) {
  return readdirSync(dir).flatMap((name) => {
    const path = join(dir, name);
    if (name === "node_modules" || name.startsWith(".")) return [];
    return statSync(path).isDirectory() ? sources(path) : SOURCE.test(name) ? [path] : [];
  });
}

/** The source file a relative specifier names, or null (a package, a stylesheet, JSON). */
function target(from, specifier) {
  if (!specifier.startsWith(".")) return null;
  const base = resolve(dirname(from), specifier);
  for (const suffix of CANDIDATES) {
    const path = base + suffix;
    if (SOURCE.test(path) && existsSync(path) && statSync(path).isFile()) return path;
  }
  return null;
}

const files = dirs.flatMap((d) => sources(resolve(root, d)));
const imports = new Map(files.map((file) => {
  const info = ts.preProcessFile(readFileSync(file, "utf8"), true, true);
  return [file, [...new Set(info.importedFiles.map((f) => target(file, f.fileName)).filter(Boolean))]];
}));

// Tarjan's strongly connected components: each component of two or more modules (or one importing
// itself) holds at least one cycle; one cycle through it is reported, as a path back to its start.
let index = 0;
const stack = [], onStack = new Set(), order = new Map(), low = new Map(), components = [];
function visit(v) {
  order.set(v, index); low.set(v, index); index++;
  stack.push(v); onStack.add(v);
  for (const w of imports.get(v) ?? []) {
    if (!imports.has(w)) continue;  // outside the checked folders
    if (!order.has(w)) { visit(w); low.set(v, Math.min(low.get(v), low.get(w))); }
    else if (onStack.has(w)) low.set(v, Math.min(low.get(v), order.get(w)));
  }
  if (low.get(v) !== order.get(v)) return;
  const component = [];
  let w;
  do { w = stack.pop(); onStack.delete(w); component.push(w); } while (w !== v);
  if (component.length > 1 || (imports.get(v) ?? []).includes(v)) components.push(component);
}
for (const file of files) if (!order.has(file)) visit(file);

/** A shortest path of imports from `start` back to itself, inside `component`. */
function cycleThrough(start, component) {
  const inside = new Set(component);
  const previous = new Map([[start, null]]);
  const queue = [start];
  while (queue.length) {
    const v = queue.shift();
    for (const w of imports.get(v) ?? []) {
      if (w === start) {
        const path = [v];
        while (previous.get(path[0]) !== null) path.unshift(previous.get(path[0]));
        return [...path, start];
      }
      if (inside.has(w) && !previous.has(w)) { previous.set(w, v); queue.push(w); }
    }
  }
  return [start, start];
}

const name = (file) => relative(root, file);
if (!components.length) {
  console.log(`no import cycles among ${files.length} modules (${dirs.join(", ")})`);
} else {
  console.error(`${components.length} import cycle(s):`);
  for (const component of components) {
    const start = [...component].sort()[0];
    console.error(`  ${cycleThrough(start, component).map(name).join(" -> ")}`);
  }
  process.exit(1);
}
