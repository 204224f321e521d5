"""People and privileges: who a phone is (visitors), roles and groups, accounts,
pairing, address rules, sign-in throttling, tokens, audit and abuse limits."""
