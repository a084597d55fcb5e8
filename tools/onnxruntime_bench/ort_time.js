// Times ONNX Runtime (the CPU library inside the npm package onnxruntime-node) on one model and
// one raw input; the counterpart of bench/forward_time. Prints one JSON object on stdout.
//   node ort_time.js MODEL.onnx INPUT.f32 H W THREADS ITERATIONS
'use strict';
const fs = require('fs');
let ort;
try {
  ort = require('onnxruntime-node');
} catch (e) {
  console.error('ort_time.js: error: onnxruntime-node is not installed (see docs/onnxruntime_bench.md)');
  process.exit(2);
}
if (process.argv[2] === '--help') {
  console.log('usage: node ort_time.js MODEL.onnx INPUT.f32 H W THREADS ITERATIONS');
  process.exit(0);
}
const [model, inputPath, h, w, threads, iterations] = process.argv.slice(2);
const nums = [h, w, threads, iterations].map(Number);
if (process.argv.length !== 8 || nums.some((v) => !Number.isInteger(v) || v < 1)) {
  console.error('ort_time.js: error: expected MODEL.onnx INPUT.f32 H W THREADS ITERATIONS (integers >= 1)');
  process.exit(2);
}
const [H, W, T, N] = nums;
(async () => {
  const buf = fs.readFileSync(inputPath);
  if (buf.length !== 3 * H * W * 4) throw new Error(`${inputPath}: expected ${3 * H * W} float32 values`);
  const data = new Float32Array(buf.buffer, buf.byteOffset, 3 * H * W);
  const session = await ort.InferenceSession.create(model, {
    intraOpNumThreads: T, interOpNumThreads: 1, executionMode: 'sequential',
    graphOptimizationLevel: 'all',
  });
  const feeds = {[session.inputNames[0]]: new ort.Tensor('float32', data, [1, 3, H, W])};
  for (let i = 0; i < 3; i++) await session.run(feeds);
  const ms = [];
  let out;
  const cpu0 = process.cpuUsage();
  for (let i = 0; i < N; i++) {
    const t0 = process.hrtime.bigint();
    out = await session.run(feeds);
    ms.push(Number(process.hrtime.bigint() - t0) / 1e6);
  }
  const cpu = process.cpuUsage(cpu0);
  const cpu_ms = (cpu.user + cpu.system) / 1000 / N; // all threads of the process, per pass
  const logits = Array.from(out[session.outputNames[0]].data);
  console.log(JSON.stringify({ms, cpu_ms, logits, version: ort.env.versions ? ort.env.versions.common : ''}));
})().catch((e) => {
  console.error(`ort_time.js: error: ${e.message}`);
  process.exit(2);
});
