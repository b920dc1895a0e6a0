// Renders an exported .glb in Babylon.js inside headless Chromium (WebGL on SwiftShader):
// every material unlit plus its lightmap, glint-view's display transform (× 2^EV, Khronos PBR
// Neutral, exact sRGB), from the camera given, and writes the canvas as PNG.
// Usage: node render.mjs CHROMIUM IN.glb OUT.png WIDTH HEIGHT CAMERA_JSON
// CAMERA_JSON: {"position":[..],"target":[..],"up":[..],"fov_y_deg":N}; exposure and the
// lightmap binding come from the file's extras.glint_lightmaps.
import fs from "node:fs";
import path from "node:path";
import { fileURLToPath } from "node:url";
import puppeteer from "puppeteer-core";

const here = path.dirname(fileURLToPath(import.meta.url));
const [chromium, glb, out, w, h, cameraJson] = process.argv.slice(2);
const width = Number(w);
const height = Number(h);
const camera = JSON.parse(cameraJson);

const browser = await puppeteer.launch({
  executablePath: chromium,
  headless: true,
  timeout: 60000,
  protocolTimeout: 120000,
  args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--disable-gpu-compositing", "--force-device-scale-factor=1"],
});
try {
  const page = await browser.newPage();
  const log = [];
  page.on("console", (m) => log.push(m.text()));
  page.on("pageerror", (e) => log.push(String(e)));
  await page.setViewport({ width, height, deviceScaleFactor: 1 });
  await page.setContent(`<html><body style="margin:0"><canvas id="c" width="${width}" height="${height}" style="width:${width}px;height:${height}px"></canvas></body></html>`);
  for (const f of ["node_modules/babylonjs/babylon.js", "node_modules/babylonjs-loaders/babylonjs.loaders.js", "msft_lightmap.js"]) {
    await page.addScriptTag({ path: path.join(here, f) });
  }
  const bytes = fs.readFileSync(glb).toString("base64");
  const result = await page.evaluate(async (b64, camera, width, height) => {
    const data = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
    const canvas = document.getElementById("c");
    const engine = new BABYLON.Engine(canvas, false, { preserveDrawingBuffer: true, useExactSrgbConversions: true, antialias: false, adaptToDeviceRatio: false });
    engine.setSize(width, height);
    const scene = new BABYLON.Scene(engine);
    scene.useRightHandedSystem = true;
    scene.clearColor = new BABYLON.Color4(0, 0, 0, 1);
    scene.ambientColor = new BABYLON.Color3(0, 0, 0);
    let extras = null;
    BABYLON.SceneLoader.OnPluginActivatedObservable.addOnce((loader) => {
      loader.onParsedObservable.addOnce((d) => { extras = d.json.extras && d.json.extras.glint_lightmaps; });
    });
    // No sRGB texture formats: the sampler would linearize RGBD's rgb before its own decode does.
    await BABYLON.AppendSceneAsync(data, scene, { pluginExtension: ".glb", pluginOptions: { gltf: { useSRGBBuffers: false } } });
    if (!extras) throw new Error("the file has no extras.glint_lightmaps");
    const bound = [];
    for (const m of scene.materials) {
      m.unlit = true;
      if (m.lightmapTexture) bound.push(m.name);
    }
    const v = (a) => new BABYLON.Vector3(a[0], a[1], a[2]);
    const cam = new BABYLON.FreeCamera("glint", v(camera.position), scene);
    cam.upVector = v(camera.up || [0, 1, 0]);
    cam.setTarget(v(camera.target));
    cam.fov = (camera.fov_y_deg * Math.PI) / 180;
    cam.minZ = 0.01;
    cam.maxZ = 1000;
    scene.activeCamera = cam;
    const ip = scene.imageProcessingConfiguration;
    ip.isEnabled = true;
    ip.exposure = Math.pow(2, extras.exposure_ev);
    ip.contrast = 1;
    ip.toneMappingEnabled = true;
    ip.toneMappingType = BABYLON.ImageProcessingConfiguration.TONEMAPPING_KHR_PBR_NEUTRAL;
    ip.vignetteEnabled = false;
    ip.colorCurvesEnabled = false;
    ip.ditheringEnabled = false;
    await scene.whenReadyAsync();
    scene.render();
    scene.render();
    return {
      png: canvas.toDataURL("image/png"),
      materials: scene.materials.map((m) => `${m.getClassName()}:${m.name}`),
      bound,
      renderer: engine.getGlInfo().renderer,
    };
  }, bytes, camera, width, height);
  fs.writeFileSync(out, Buffer.from(result.png.split(",")[1], "base64"));
  console.log(JSON.stringify({ renderer: result.renderer, materials: result.materials.length, lightmapped: result.bound.length, log }));
} finally {
  await browser.close();
}
