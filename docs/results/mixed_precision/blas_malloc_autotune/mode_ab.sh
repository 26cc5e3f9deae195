cd /work/abX
for mode in "" max-autotune-no-cudagraphs; do
  echo "mode=[$mode]"; MCP_MODE=$mode PYTHONPATH=/work/abX timeout 400 .venv/bin/python time_step.py (this folder) mixed 300 2>&1 | grep -v Warning | tail -3
done
