// Write tests/data/meshopt/color_khr.json: vertex colours compressed with KHR_meshopt_compression's COLOR filter
// (YCoCg) by meshoptimizer's official JavaScript/WebAssembly encoder (npm package "meshoptimizer" 1.3.0), which
// has the colour filter encoder the PyPI package of tools/make_meshopt_fixtures.py lacks; and what its decoder
// makes of them. Not needed by the tests. To regenerate:
//
//     mkdir /tmp/mo-npm && cd /tmp/mo-npm && npm install meshoptimizer@1.3.0
//     NODE_PATH=/tmp/mo-npm/node_modules node tools/make_meshopt_color_fixture.mjs
//
// The colours: one per vertex of tests/data/meshopt/sphere_khr.glb (559), RGBA in [0, 1] from a fixed formula
// (the test computes it again),
// encoded 8-bit (stride 4) at 8 and 6 bits, and 16-bit (stride 8) at 12 bits, each then compressed with the
// vertex codec version 1 (ATTRIBUTES).
import { createRequire } from "node:module";
import { writeFileSync } from "node:fs";
import { dirname, join } from "node:path";
import { fileURLToPath, pathToFileURL } from "node:url";

const require = createRequire(join(process.env.NODE_PATH || ".", "x.js"));
const { MeshoptEncoder, MeshoptDecoder } = await import(pathToFileURL(require.resolve("meshoptimizer")).href);

await MeshoptEncoder.ready;
await MeshoptDecoder.ready;

const count = 559;
const src = new Float32Array(count * 4);
for (let i = 0; i < count; ++i) {
	const t = i / (count - 1);
	src[i * 4 + 0] = 0.5 + 0.5 * Math.sin(6.2831853 * t);
	src[i * 4 + 1] = 0.5 + 0.5 * Math.sin(6.2831853 * t + 2.0944);
	src[i * 4 + 2] = 0.5 + 0.5 * Math.sin(6.2831853 * t + 4.1888);
	src[i * 4 + 3] = 0.25 + 0.75 * t;
}

const out = { encoder: "meshoptimizer 1.3.0 (npm)", count, streams: [] };
for (const [stride, bits] of [[4, 8], [4, 6], [8, 12]]) {
	const filtered = MeshoptEncoder.encodeFilterColor(src, count, stride, bits);
	const compressed = MeshoptEncoder.encodeVertexBufferLevel(filtered, count, stride, 2, 1);
	const decoded = new Uint8Array(count * stride);
	MeshoptDecoder.decodeGltfBuffer(decoded, count, stride, compressed, "ATTRIBUTES", "COLOR");
	out.streams.push({
		stride, bits,
		compressed: Buffer.from(compressed).toString("base64"),
		decoded: Buffer.from(decoded).toString("base64"),
	});
}
const path = join(dirname(fileURLToPath(import.meta.url)), "..", "tests", "data", "meshopt", "color_khr.json");
writeFileSync(path, JSON.stringify(out));
console.error(path);
