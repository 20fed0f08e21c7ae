// The host side of MCP Apps (SEP-1865) for the browser tests only: bundled by
// scripts/vendor_refresh.sh into tests/browser/vendor/ext-apps-host.js as one classic script
// that defines the global `McpHost`, loaded by tests/browser/host.html. Never served by the
// server itself.
export { AppBridge, PostMessageTransport, getToolUiResourceUri, RESOURCE_MIME_TYPE } from '@modelcontextprotocol/ext-apps/app-bridge';
export { Client, StreamableHTTPClientTransport } from '@modelcontextprotocol/client';
