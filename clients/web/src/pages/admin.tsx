// SPDX-License-Identifier: GPL-3.0-or-later
// Placeholder while the page is being written; replaced in this issue.
export function AdminPage() {
  return <section><h1>Admin</h1><p>Being built.</p></section>;
}
