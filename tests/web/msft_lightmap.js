// glint's binding of MSFT_lightmap for Babylon.js, whose glTF loader no longer ships that
// extension: the material's lightmapTexture (on the UV set its texCoord names) multiplies the
// lit colour (useLightmapAsShadowmap), decoded as RGBD when the file's
// extras.glint_lightmaps.encoding says so, and scaled by its `scale` (docs/export.md).
(function () {
  const NAME = "MSFT_lightmap";
  BABYLON.GLTF2.registerGLTFExtension(NAME, true, (loader) => ({
    name: NAME,
    enabled: true,
    loadMaterialPropertiesAsync(context, material, babylonMaterial) {
      const ext = material.extensions && material.extensions[NAME];
      if (!ext) return null;
      const info = (loader.gltf.extras && loader.gltf.extras.glint_lightmaps) || {};
      const props = loader.loadMaterialPropertiesAsync(context, material, babylonMaterial);
      const lightmap = loader.loadTextureInfoAsync(`${context}/extensions/${NAME}/lightmapTexture`, ext.lightmapTexture, (texture) => {
        babylonMaterial.lightmapTexture = texture;
        babylonMaterial.useLightmapAsShadowmap = true;
      }).then((texture) => {
        // Set once loaded: the loader settles a texture's colour space after `assign`. RGBD's
        // decode linearizes its rgb itself; an sRGB page is linearized by the sampler path.
        texture.isRGBD = info.encoding === "rgbd";
        texture.gammaSpace = info.encoding === "srgb";
        texture.level = info.scale === undefined ? 1 : info.scale;
        // The material's shader defines (GAMMALIGHTMAP, RGBDLIGHTMAP) follow only on a mark.
        babylonMaterial.markAsDirty(BABYLON.Material.TextureDirtyFlag);
      });
      return Promise.all([props, lightmap]).then(() => {});
    },
    dispose() {},
  }));
})();
