// SPDX-License-Identifier: GPL-3.0-or-later
//
// Builds the console: TypeScript types and descriptors from
// proto/hdrstereo/v1 (Debian's protoc with @bufbuild/protoc-gen-es, into
// gen/, not committed), then one bundle by esbuild, written with the page
// and the style sheet into OUTDIR (default dist/). The daemon serves OUTDIR;
// CMake builds it into <build>/share/hdrstereo/web.
//
// Usage: node build.mjs [--outdir DIR] [--check]   (--check: tsc too)
import { execFileSync } from "node:child_process";
import {
  copyFileSync, existsSync, mkdirSync, mkdtempSync, readdirSync, readFileSync, renameSync,
  rmSync,
} from "node:fs";
import { dirname, join, resolve } from "node:path";
import { fileURLToPath } from "node:url";
import * as esbuild from "esbuild";

const here = dirname(fileURLToPath(import.meta.url));
const args = process.argv.slice(2);
const outIndex = args.indexOf("--outdir");
const outdir = resolve(outIndex >= 0 ? args[outIndex + 1] : join(here, "dist"));
const protoRoot = resolve(here, "../../proto");
const gen = join(here, "gen");

// Generated into a private folder, then moved into gen/ file by file (a
// rename each, so another build reading gen/ at the same moment never sees
// a missing or half-written file), and only where the text changed.
const fresh = mkdtempSync(join(here, ".gen-"));
try {
  const protos = readdirSync(join(protoRoot, "hdrstereo/v1"))
    .filter((f) => f.endsWith(".proto"))
    .map((f) => join(protoRoot, "hdrstereo/v1", f));
  execFileSync("protoc", [
    `--plugin=protoc-gen-es=${join(here, "node_modules/.bin/protoc-gen-es")}`,
    `--es_out=${fresh}`, "--es_opt=target=ts", `-I${protoRoot}`, ...protos,
  ], { stdio: "inherit" });
  const made = join(fresh, "hdrstereo/v1");
  const target = join(gen, "hdrstereo/v1");
  mkdirSync(target, { recursive: true });
  const current = new Set(readdirSync(made));
  for (const name of current) {
    const text = readFileSync(join(made, name), "utf8");
    const old = existsSync(join(target, name)) ? readFileSync(join(target, name), "utf8") : null;
    if (text !== old) renameSync(join(made, name), join(target, name));
  }
  for (const name of readdirSync(target)) {
    if (!current.has(name)) rmSync(join(target, name));  // a proto removed
  }
} finally {
  rmSync(fresh, { recursive: true, force: true });
}

if (args.includes("--check")) {
  execFileSync(join(here, "node_modules/.bin/tsc"), ["--noEmit", "-p", here],
               { stdio: "inherit" });
}

mkdirSync(outdir, { recursive: true });
await esbuild.build({
  entryPoints: [join(here, "src/main.tsx")],
  bundle: true,
  minify: true,
  sourcemap: true,
  format: "esm",
  target: "es2022",
  outfile: join(outdir, "console.js"),
  logLevel: "warning",
});
copyFileSync(join(here, "src/index.html"), join(outdir, "index.html"));
copyFileSync(join(here, "src/console.css"), join(outdir, "console.css"));
