// A real S7 server for the tests: node-snap7's S7Server on loopback, with every
// area registered, driven over stdin/stdout so a test can check values both ways.
//
//   node snap7_server.js PORT
//   -> "READY PORT"                       once listening (or "ERROR text" and exit 1)
//   <- "get AREA DB OFFSET LEN"           -> "OK hexbytes"
//   <- "set AREA DB OFFSET hexbytes"      -> "OK"
//   <- "quit"
// AREA is one of PE PA MK CT TM DB (DB uses the DB number; the others ignore it).
'use strict';

const readline = require('readline');

let snap7;
try {
  snap7 = require('node-snap7');
} catch (e) {
  process.stdout.write(`ERROR node-snap7 is not installed (run scripts/setup-s7-peer): ${e.message}\n`);
  process.exit(1);
}

const port = Number(process.argv[2] || 102);
const server = new snap7.S7Server();
const areas = {
  PE: { code: server.srvAreaPE, buffers: { 0: Buffer.alloc(256) } },
  PA: { code: server.srvAreaPA, buffers: { 0: Buffer.alloc(256) } },
  MK: { code: server.srvAreaMK, buffers: { 0: Buffer.alloc(256) } },
  CT: { code: server.srvAreaCT, buffers: { 0: Buffer.alloc(512) } },
  TM: { code: server.srvAreaTM, buffers: { 0: Buffer.alloc(512) } },
  DB: { code: server.srvAreaDB, buffers: { 1: Buffer.alloc(256), 2: Buffer.alloc(64), 3: Buffer.alloc(1024) } },
};

for (const [name, area] of Object.entries(areas)) {
  for (const [index, buf] of Object.entries(area.buffers)) {
    const ok = name === 'DB' ? server.RegisterArea(area.code, Number(index), buf) : server.RegisterArea(area.code, buf);
    if (!ok) {
      process.stdout.write(`ERROR cannot register ${name}${index}\n`);
      process.exit(1);
    }
  }
}

server.SetParam(server.LocalPort, port);
if (server.StartTo('127.0.0.1') === false) {
  process.stdout.write(`ERROR cannot listen on 127.0.0.1:${port}: ${server.ErrorText(server.LastError())}\n`);
  process.exit(1);
}
process.stdout.write(`READY ${port}\n`);

function area(name, db) {
  const a = areas[name];
  if (!a) return null;
  return { code: a.code, index: name === 'DB' ? Number(db) : 0 };
}

const rl = readline.createInterface({ input: process.stdin });
rl.on('line', (line) => {
  const [cmd, name, db, offset, arg] = line.trim().split(/\s+/);
  if (cmd === 'quit') {
    server.Stop();
    process.exit(0);
  }
  const a = area(name, db);
  if (!a) {
    process.stdout.write(`ERROR bad command: ${line}\n`);
    return;
  }
  // GetArea returns a copy of the server's memory; SetArea copies into it.
  const mem = a.code === server.srvAreaDB ? server.GetArea(a.code, a.index) : server.GetArea(a.code);
  const off = Number(offset);
  if (cmd === 'get') {
    process.stdout.write(`OK ${mem.subarray(off, off + Number(arg)).toString('hex')}\n`);
  } else if (cmd === 'set') {
    Buffer.from(arg, 'hex').copy(mem, off);
    if (a.code === server.srvAreaDB) server.SetArea(a.code, a.index, mem);
    else server.SetArea(a.code, mem);
    process.stdout.write('OK\n');
  } else {
    process.stdout.write(`ERROR bad command: ${line}\n`);
  }
});
rl.on('close', () => {
  server.Stop();
  process.exit(0);
});
