// The test OpenID Provider: oidc-provider from npm (OpenID Certified), run as it is by
// tests/oidc/provider.py, which writes this process's configuration file: the issuer
// (where the tests reach it), the port it listens on, its signing key and the accounts
// that can sign in (login name -> claims).
//
// Its own login page (oidc-provider's development interactions: any password) signs
// people in; clients register themselves (dynamic registration), so each test has a
// client with its own server's redirect URI. Consent is taken as given, as a campus
// provider whose administrator registered tagwall does.
//
// Beside the provider, three test controls under /test/ do what no well-behaved
// provider does on request: add an account, set the provider's clock off by some
// seconds, and hand out a given ID token in a client's next token response (a token a
// test forged, or signed with wrong claims), as a broken or compromised provider would.
import { readFileSync } from 'node:fs';

import Provider from 'oidc-provider';

const config = JSON.parse(readFileSync(process.argv[2], 'utf8'));
const accounts = new Map(Object.entries(config.accounts));
const handOut = new Map(); // client id -> the ID token its next token response carries

const realNow = Date.now;
let skewMs = 0;
Date.now = () => realNow() + skewMs; // every time the provider reads (epochTime, cookies)

const provider = new Provider(config.issuer, {
  jwks: { keys: [config.signing_key] },
  cookies: { keys: [config.cookie_key] },
  claims: {
    openid: ['sub'],
    email: ['email', 'email_verified'],
    profile: ['name', 'preferred_username'],
    groups: ['groups'],
  },
  features: {
    devInteractions: { enabled: true },
    registration: { enabled: true },
    rpInitiatedLogout: { enabled: true },
  },
  pkce: { required: () => true },
  async findAccount(ctx, id) {
    const claims = accounts.get(id);
    if (claims === undefined) return undefined;
    return { accountId: id, claims: async () => ({ ...claims, sub: id }) };
  },
  async loadExistingGrant(ctx) {
    const { client, session } = ctx.oidc;
    const grantId = ctx.oidc.result?.consent?.grantId || session.grantIdFor(client.clientId);
    if (grantId) return ctx.oidc.provider.Grant.find(grantId);
    const grant = new ctx.oidc.provider.Grant({ clientId: client.clientId, accountId: session.accountId });
    grant.addOIDCScope('openid email profile groups');
    await grant.save();
    return grant;
  },
});

async function body(ctx) {
  const chunks = [];
  for await (const chunk of ctx.req) chunks.push(chunk);
  return JSON.parse(Buffer.concat(chunks).toString('utf8') || '{}');
}

provider.use(async (ctx, next) => {
  if (ctx.method === 'POST' && ctx.path.startsWith('/test/')) {
    const given = await body(ctx);
    switch (ctx.path) {
      case '/test/accounts':
        accounts.set(given.login, given.claims);
        break;
      case '/test/clock':
        skewMs = given.skew_s * 1000;
        break;
      case '/test/id-token':
        handOut.set(given.client_id, given.id_token);
        break;
      default:
        ctx.throw(404);
    }
    ctx.status = 204;
    return;
  }
  await next();
  if (ctx.oidc?.route === 'token' && ctx.status === 200 && ctx.body?.id_token) {
    const clientId = ctx.oidc.client?.clientId;
    if (handOut.has(clientId)) {
      ctx.body = { ...ctx.body, id_token: handOut.get(clientId) };
      handOut.delete(clientId);
    }
  }
});

provider.listen(config.port, '127.0.0.1', () => {
  process.stdout.write(`listening on ${config.port} as ${config.issuer}\n`);
});
