// SPDX-License-Identifier: GPL-3.0-or-later
//
// How live view waits: the capture job a refusal names (StreamPreview is
// refused with FAILED_PRECONDITION "the hardware is in use by a capture
// job: capture job 12 (session lab); ..." while a capture holds the rig),
// and the back-off between attempts after an error.

export function captureJobIn(message: string): bigint | undefined {
  const m = /capture job (\d+)/.exec(message);
  return m ? BigInt(m[1]) : undefined;
}

// Milliseconds before attempt `failures` + 1 after `failures` failures in
// a row: 1 s, 2 s, 4 s, ... at most 15 s.
export function retryDelayMs(failures: number): number {
  return Math.min(1000 * 2 ** Math.max(0, failures - 1), 15000);
}
