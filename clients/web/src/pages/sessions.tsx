// SPDX-License-Identifier: GPL-3.0-or-later
// Placeholder while the page is being written; replaced in this issue.
export function SessionsPage({ params }: { params: string[] }) {
  return <section><h1>Sessions</h1><p>Being built ({params.join('/')}).</p></section>;
}
