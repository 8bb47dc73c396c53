// The interop tests' rule for missing tools (tests/README.md): exit 77
// (ctest SKIP_RETURN_CODE) unless PRT_REQUIRE_TOOLS=1, then fail (exit 1).
'use strict';
function missing(what) {
  if (process.env.PRT_REQUIRE_TOOLS === '1') {
    console.error(`FAIL: ${what} is missing and PRT_REQUIRE_TOOLS=1`);
    process.exit(1);
  }
  console.error(`SKIP: ${what} is missing (npm ci --prefix tests/js; scripts/install-deps.sh)`);
  process.exit(77);
}
// playwright-core's chromium and the Chromium it drives (PRT_CHROMIUM, else
// Debian's /usr/bin/chromium), or missing() for either.
function chromiumOrSkip() {
  let chromium;
  try {
    ({ chromium } = require('playwright-core'));
  } catch (e) {
    missing('the npm package playwright-core');
  }
  const executable = process.env.PRT_CHROMIUM || '/usr/bin/chromium';
  if (!require('fs').existsSync(executable)) missing('Chromium (' + executable + ')');
  return { chromium, executable };
}

// The test's --name value pairs; usage and exit 2 without --prt and --source.
function testArgs(script) {
  const args = {};
  for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];
  if (!args.prt || !args.source) {
    console.error(`usage: node ${script} --prt BUILD/prt --source SRC [--images DIR]`);
    process.exit(2);
  }
  return args;
}

// Runs `cmd` with `argv`; resolves to its stdout, rejects with its stderr.
// prt render without an OpenGL 4.5 context is missing() (the GL tests' rule,
// tests/README.md), not a failure, unless PRT_REQUIRE_GL=1.
function run(cmd, argv) {
  const { execFile } = require('child_process');
  return new Promise((resolve, reject) => {
    execFile(cmd, argv, { maxBuffer: 1 << 26 }, (e, stdout, stderr) => {
      if (!e) return resolve(stdout);
      if (/no OpenGL 4\.5/.test(stderr) && process.env.PRT_REQUIRE_GL !== '1') missing('an OpenGL 4.5 context for prt render');
      reject(new Error(`${require('path').basename(cmd)} ${argv.join(' ')}: exit ${e.code}\n${stderr}`));
    });
  });
}

// prt render's coverage of a W x H frame from its EXR's alpha (prt render
// --alpha), read with three's EXRLoader from `threeDir` (its rows come from
// the bottom): 1 where alpha > 0.5, rows from the top.
async function exrCoverage(threeDir, exr, W, H) {
  const path = require('path');
  const { EXRLoader } = await import(path.join(threeDir, 'examples', 'jsm', 'loaders', 'EXRLoader.js'));
  const THREE = await import(path.join(threeDir, 'build', 'three.module.js'));
  const buf = require('fs').readFileSync(exr);
  const e = new EXRLoader().setDataType(THREE.FloatType).parse(buf.buffer.slice(buf.byteOffset, buf.byteOffset + buf.length));
  if (e.width !== W || e.height !== H) throw new Error(`${exr}: ${e.width}x${e.height}, expected ${W}x${H}`);
  const mask = new Uint8Array(W * H);
  for (let y = 0; y < H; ++y)
    for (let x = 0; x < W; ++x) mask[y * W + x] = e.data[4 * ((H - 1 - y) * W + x) + 3] > 0.5 ? 1 : 0;
  return mask;
}

module.exports = { missing, chromiumOrSkip, testArgs, run, exrCoverage };
