// SPDX-License-Identifier: GPL-3.0-or-later
// Placeholder while the page is being written; replaced in this issue.
export function RigPage() {
  return <section><h1>Rig</h1><p>Being built.</p></section>;
}
