// The globes as derma render draws them (forward.wgsl's fs_eye): each pixel on the cornea refracts
// its view ray at the 7.8 mm corneal sphere (n = 1.376) onto the iris plane 3.6 mm behind the
// apex (Le Grand's schematic eye), the pupil drawn at its morphs' diameter through the texture's
// coordinates, and the tear film's wet highlight (GGX at roughness 0.05, F0 of n = 1.376).
import * as THREE from 'three';

// Le Grand's eye in metres (the GLB's unit), as forward.wgsl.
const CORNEA_RADIUS = 0.0078;
const CORNEA_PROUD = 0.0011;
const IRIS_DEPTH = 0.0036;
const LIMBUS_RADIUS = 0.00585;
const CORNEA_N = 1.376;
// derma-head's eye: the texture's pupil and iris radii in UV (a 4 mm pupil, 29° iris).
const PUPIL_UV = (0.5 * 9.6) / 180;
const IRIS_UV = (0.5 * 29) / 180;

const FRAGMENT = /* glsl */ `
uniform vec3 eyeCentre;
uniform vec3 eyeX;
uniform vec3 eyeY;
uniform vec3 eyeZ;
uniform float eyeRadius;
uniform float pupilUv;
// The UV to read for the globe's (derma) uv with the pupil drawn at pupilUv (eye::dilated_uv).
vec2 dilatedUv(vec2 uv) {
  vec2 d = uv - vec2(0.5);
  float r = length(d);
  if (r <= 0.0 || r >= ${IRIS_UV} || pupilUv <= 0.0) return uv;
  float rt = r < pupilUv ? r / pupilUv * ${PUPIL_UV}
    : ${PUPIL_UV} + (r - pupilUv) / (${IRIS_UV} - pupilUv) * (${IRIS_UV - PUPIL_UV});
  return vec2(0.5) + d * (rt / r);
}
// The texel of the globe's point at angle theta from the axis and azimuth phi (derma-head's
// eye::uv_of), as the GLB stores it (v down).
vec2 globeUv(float theta, float phi) {
  vec2 uv = dilatedUv(vec2(0.5) + 0.5 * (theta / PI) * vec2(cos(phi), sin(phi)));
  return vec2(uv.x, 1.0 - uv.y);
}
// Where the view ray to view-space point p meets the iris through the cornea: its texel; else
// the globe's own (plain: the mesh's UV, the pupil morphs in it).
vec2 corneaUv(vec3 p, vec2 plain) {
  vec3 dir = normalize(p);
  vec3 cc = eyeCentre + eyeZ * (eyeRadius + ${CORNEA_PROUD} - ${CORNEA_RADIUS});
  float b = dot(-cc, dir);
  float disc = b * b - (dot(cc, cc) - ${CORNEA_RADIUS * CORNEA_RADIUS});
  if (disc < 0.0) return plain;
  vec3 q = dir * (-b - sqrt(disc));
  float hLimbus = sqrt(max(eyeRadius * eyeRadius - ${LIMBUS_RADIUS * LIMBUS_RADIUS}, 0.0));
  if (dot(q - eyeCentre, eyeZ) <= hLimbus) return plain;
  vec3 r = refract(dir, normalize(q - cc), ${1 / CORNEA_N});
  float plane = eyeRadius + ${CORNEA_PROUD} - ${IRIS_DEPTH};
  float den = dot(r, eyeZ);
  vec3 s = den < -1e-4 ? q + r * ((plane - dot(q - eyeCentre, eyeZ)) / den) : q;
  vec2 local = vec2(dot(s - eyeCentre, eyeX), dot(s - eyeCentre, eyeY));
  return globeUv(asin(min(length(local) / eyeRadius, 1.0)), atan(local.y, local.x));
}
`;

/**
 * Gives the globe `mesh` (under its gaze `pivot` at the globe's centre, the head's axes in the
 * mesh's frame; `radius` in metres) derma render's eye: refraction, the pupil's dilation and the
 * wet tear film. `pupilMm()` returns the pupil's diameter to draw.
 */
export function corneaMaterial(mesh, pivot, radius, pupilMm) {
  const old = mesh.material;
  const m = new THREE.MeshPhysicalMaterial({ map: old.map, roughness: 0.05, metalness: 0, ior: CORNEA_N });
  const u = {
    eyeCentre: { value: new THREE.Vector3() },
    eyeX: { value: new THREE.Vector3() },
    eyeY: { value: new THREE.Vector3() },
    eyeZ: { value: new THREE.Vector3() },
    eyeRadius: { value: radius },
    pupilUv: { value: PUPIL_UV },
  };
  m.onBeforeCompile = (shader) => {
    Object.assign(shader.uniforms, u);
    shader.fragmentShader = shader.fragmentShader
      .replace('#include <common>', `#include <common>\n${FRAGMENT}`)
      .replace('#include <map_fragment>', 'diffuseColor *= texture2D(map, corneaUv(-vViewPosition, vMapUv));');
  };
  // The globe's frame in view space, each frame it is drawn.
  const axis = new THREE.Vector3();
  const normal = new THREE.Matrix3();
  mesh.onBeforeRender = (_r, _s, camera) => {
    const view = new THREE.Matrix4().multiplyMatrices(camera.matrixWorldInverse, mesh.matrixWorld);
    normal.setFromMatrix4(view);
    pivot.getWorldPosition(u.eyeCentre.value).applyMatrix4(camera.matrixWorldInverse);
    u.eyeX.value.copy(axis.set(1, 0, 0).applyMatrix3(normal).normalize());
    u.eyeY.value.copy(axis.set(0, 1, 0).applyMatrix3(normal).normalize());
    u.eyeZ.value.copy(axis.set(0, 0, 1).applyMatrix3(normal).normalize());
    u.pupilUv.value = pupilUvRadius(pupilMm(), 1000 * radius);
  };
  m.userData.cornea = true;
  mesh.material = m;
  return m;
}

/** The UV radius of a pupil `mm` across on a globe of radius `radiusMm` (derma-head's
 * eye::pupil_uv_radius). */
export function pupilUvRadius(mm, radiusMm) {
  return (0.5 * Math.asin(Math.min(1, (0.5 * mm) / radiusMm))) / Math.PI;
}
