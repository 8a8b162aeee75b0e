// The workbench bundle: one page, its script and style under assets/ with hashed names
// (the engine caches those for good). three.js is most of the bundle.
import { defineConfig } from 'vite';

export default defineConfig({
  base: '/',
  build: {
    assetsDir: 'assets',
    chunkSizeWarningLimit: 1024,
    sourcemap: false,
  },
  // The viewer's mesh worker (`src/worker.js`) is a module worker of the page's origin.
  worker: { format: 'es' },
});
