// simplebot viewer: the layers it draws and their colours, the costmap palette and the binary frames of /frame
// (viewer.js draws them).
"use strict";

window.SimplebotFrames = (() => {
  // Cost colours as RViz's "costmap" scheme: free clear, 1..98 blue to red, inscribed cyan, lethal purple.
  const COST = {
    unknown: [112, 128, 144, 90],
    inscribed: [0, 255, 255, 255],
    lethal: [160, 0, 200, 255],
  };
  const LAYERS = [
    // name, label, colour (for the legend and the drawing)
    ["global_costmap", "global costmap", "#a000c8"],
    ["local_costmap", "local costmap", "#00c8c8"],
    ["grid", "1 m grid", "#ccc"],
    ["trail", "odometry trail", "#6a6"],
    ["global_plan", "global plan (GlobalPlanner/plan)", "#00a000"],
    ["local_plan", "local plan (TEB local_plan)", "#0050ff"],
    ["teb_poses", "teb poses", "#b8860b"],
    ["moving_obstacles", "moving obstacles (ground truth)", "#ff8c00"],
    ["front_scan", "front scan", "#e00000"],
    ["back_scan", "back scan", "#f07000"],
    ["footprint", "footprint", "#222"],
    ["robot", "robot body", "#777"],
    ["goal", "current goal", "#c00060"],
  ];
  const COLOURS = Object.fromEntries(LAYERS.map(([name, , colour]) => [name, colour]));

  // -- palette -----------------------------------------------------------------------------------
  const PALETTE = new Uint8ClampedArray(256 * 4);
  for (let v = 0; v < 256; v++) {
    let rgba;
    if (v === 0) rgba = [0, 0, 0, 0];
    else if (v <= 98) {
      const t = (v - 1) / 97;
      rgba = [Math.round(255 * t), 0, Math.round(255 * (1 - t)), 150 + Math.round(80 * t)];
    } else if (v === 99) rgba = COST.inscribed;
    else if (v === 100) rgba = COST.lethal;
    else rgba = COST.unknown;  // 255: unknown
    PALETTE.set(rgba, v * 4);
  }

  function gridImage(meta, cells) {
    const image = document.createElement("canvas");
    image.width = meta.width;
    image.height = meta.height;
    const g = image.getContext("2d");
    const data = g.createImageData(meta.width, meta.height);
    const px = data.data;
    // Row 0 of the grid is the lowest y; the world transform flips y, so rows go in as they are.
    for (let i = 0; i < cells.length; i++) {
      const o = cells[i] * 4;
      const j = i * 4;
      px[j] = PALETTE[o]; px[j + 1] = PALETTE[o + 1]; px[j + 2] = PALETTE[o + 2]; px[j + 3] = PALETTE[o + 3];
    }
    g.putImageData(data, 0, 0);
    return image;
  }

  // -- frames --------------------------------------------------------------------------------------
  function decode(buffer) {
    const view = new DataView(buffer);
    const length = view.getUint32(0, true);
    const header = JSON.parse(new TextDecoder().decode(new Uint8Array(buffer, 4, length)));
    const base = Math.ceil((4 + length) / 8) * 8;
    const arrays = header.buffers.map((b) => b.type === "u8"
      ? new Uint8Array(buffer, base + b.offset, b.bytes)
      : new Float32Array(buffer, base + b.offset, b.bytes / 4));
    return { header, arrays };
  }

  return { LAYERS, COLOURS, gridImage, decode };
})();
