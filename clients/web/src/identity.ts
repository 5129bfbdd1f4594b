// SPDX-License-Identifier: GPL-3.0-or-later
//
// Who is signed in, and what the one role table lets them do: the console
// hides controls a role may not use (the server refuses them anyway).
import { createContext } from "preact";
import { useContext } from "preact/hooks";
import { Role } from "../gen/hdrstereo/v1/common_pb";

export interface Me {
  principal: string;
  role: Role;
  authMethod: string;
}

export const MeContext = createContext<Me | null>(null);

export function useMe(): Me {
  const me = useContext(MeContext);
  if (!me) throw new Error("useMe outside a signed-in page");
  return me;
}

// True when `me` holds at least `needed` (viewer < operator < admin).
export function atLeast(me: Me, needed: Role): boolean {
  return me.role >= needed && me.role !== Role.UNSPECIFIED;
}

export function roleName(role: Role): string {
  return Role[role]?.toLowerCase() ?? "none";
}

export { Role };
