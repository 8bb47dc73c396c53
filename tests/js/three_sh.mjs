// three.js itself against prt: loads `prt project --convention three` JSON
// into THREE.SphericalHarmonics3 (fromArray, as LightProbe takes it) and
// compares getAt / getIrradianceAt with prt's own reconstruction and
// irradiance at the directions of EXPECT (written by test_three_interop from
// prt's coefficients). Also loads prt's own-convention JSON the same way and
// expects it NOT to match (the Condon-Shortley sign three lacks), so the
// comparison can fail.
//
// usage: node three_sh.mjs THREE_JSON PRT_JSON EXPECT_JSON
// exit: 0 pass, 1 fail, 77 three.js not installed (npm ci --prefix tests/js).
import { readFileSync } from 'node:fs';

// three's getAt / getIrradianceAt use 6-digit constants (0.282095, 0.429043,
// ...): up to 2.4e-6 relative each; 1e-5 of the largest value bounds nine
// terms (the same bound as tests/test_sh_convention.cpp's kThreeConstantsTol).
const TOLERANCE = 1e-5;
// Without the sign conversion the error is of the order of the lighting's
// directional part: far above this.
const MISMATCH = 1e-2;

let THREE;
try {
  THREE = await import('three');
} catch (e) {
  console.log(`three.js not found (${e.message}); run npm ci --prefix tests/js`);
  process.exit(77);
}

const [threeJson, prtJson, expectJson] = process.argv.slice(2).map((p) => JSON.parse(readFileSync(p, 'utf8')));
if (threeJson.convention !== 'three') {
  console.log(`expected "convention": "three", got ${JSON.stringify(threeJson.convention)}`);
  process.exit(1);
}

function worst(json, method, expected) {
  const sh = new THREE.SphericalHarmonics3().fromArray(json.coefficients.flat());
  const probe = new THREE.LightProbe(sh);  // what a scene would hold
  let scale = 0, diff = 0;
  const target = new THREE.Vector3();
  expectJson.directions.forEach((d, i) => {
    probe.sh[method](new THREE.Vector3(d[0], d[1], d[2]), target);
    const want = expected[i];
    const got = [target.x, target.y, target.z];
    for (let c = 0; c < 3; ++c) {
      scale = Math.max(scale, Math.abs(want[c]));
      diff = Math.max(diff, Math.abs(got[c] - want[c]));
    }
  });
  return diff / scale;
}

let ok = true;
const report = (what, value, pass) => {
  console.log(`${what}: worst ${value.toExponential(3)} of the largest value (${pass ? 'ok' : 'FAIL'})`);
  ok = ok && pass;
};
const r = worst(threeJson, 'getAt', expectJson.radiance);
const e = worst(threeJson, 'getIrradianceAt', expectJson.irradiance);
report('getAt vs prt radiance', r, r < TOLERANCE);
report('getIrradianceAt vs prt irradiance', e, e < TOLERANCE);
const unconverted = worst(prtJson, 'getAt', expectJson.radiance);
report('prt-convention coefficients in three (must not match)', unconverted, unconverted > MISMATCH);
console.log(`three.js r${THREE.REVISION}, ${expectJson.directions.length} directions, tolerance ${TOLERANCE}`);
process.exit(ok ? 0 : 1);
