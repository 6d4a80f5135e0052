// Camera-frame geometry shared by the 2D and 3D views. Points are the API's: OpenCV camera frame
// (x right, y down, z forward), metres.

/// The pixel of the full-resolution image a camera-frame point projects to, or null behind the
/// camera.
export function project(intrinsics, x, y, z) {
  if (!(z > 1e-6)) return null;
  return [intrinsics.fx * x / z + intrinsics.cx, intrinsics.fy * y / z + intrinsics.cy];
}

/// The 12 edges of a box given as 8 corners in EstimateBoxResponse order (front face TL, TR,
/// BR, BL, then the back face).
export const BOX_EDGES = [[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4],
                          [0, 4], [1, 5], [2, 6], [3, 7]];

function distance(a, b) {
  return Math.hypot(a.x - b.x, a.y - b.y, a.z - b.z);
}

/// Width, height and depth of a box from its corners, centimetres.
export function boxSizeCm(corners) {
  return {
    width: 100 * distance(corners[0], corners[1]),
    height: 100 * distance(corners[0], corners[3]),
    depth: 100 * distance(corners[0], corners[4]),
  };
}

export function formatSize(size) {
  return `${size.width.toFixed(1)} × ${size.height.toFixed(1)} × ${size.depth.toFixed(1)} cm`;
}

/// 0xRRGGBB -> "rgba(r, g, b, alpha)".
export function cssColour(rgb, alpha = 1) {
  return `rgba(${(rgb >> 16) & 255}, ${(rgb >> 8) & 255}, ${rgb & 255}, ${alpha})`;
}

/// The overlay colours, the same in both views so a thing is found by colour and id.
export const COLOURS = { object: 0xffb020, bowl: 0x3ad0ff, taught: 0x7dff6a, userBox: 0xff4fd8 };

/// "O3" for object track 3, "B5" for bowl track 5, "P2" for plane track 2.
export function objectLabel(object) {
  return (object.kind === 'BOWL' ? 'B' : 'O') + object.id;
}

/// Nanoseconds (a decimal string, as the JSON mapping writes int64) as seconds, for people.
export function nsToSeconds(ns) {
  return (Number(BigInt(ns) / 1000n) / 1e6).toFixed(3);
}
