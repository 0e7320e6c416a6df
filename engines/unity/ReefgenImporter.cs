// reefgen's Unity importer (docs/ENGINES.md "Unity"): one menu click makes
// Terrains of a reefgen Unity bundle (`--for unity` of generate, infer,
// erode or world): the heights, the terrain size and position, the eight
// material layers with their weights, and neighbouring tiles connected.
// Put this file anywhere under Assets/ (it is editor-only; an Editor folder
// is the usual place), then Tools > reefgen > Import Unity bundle... and pick
// the bundle folder (the one holding reefgen-unity.json). Each tile's
// TerrainData, its eight TerrainLayers and their colour swatches are saved
// under Assets/reefgen/NAME/; the Terrains go into the open scene under a
// parent object NAME, the island's centre at the world's origin and sea level
// at Y = 0.
#if UNITY_EDITOR
using System;
using System.IO;
using UnityEditor;
using UnityEngine;

public static class ReefgenImporter
{
    // reefgen-unity.json, as reefgen writes it (field names are its keys).
    [Serializable]
    public class Tile
    {
        public string raw;
        public string[] splat;
        public int x;
        public int z;
        public float[] position_m;
    }

    [Serializable]
    public class Bundle
    {
        public string engine;
        public string name;
        public Tile[] tiles;
        public int tiles_per_axis;
        public int tile_side_px;
        public int alphamap_px;
        public float[] range_m;
        public float[] terrain_size_m;
        public string[] layers;
        public float[] layer_colours;
    }

    [MenuItem("Tools/reefgen/Import Unity bundle...")]
    public static void ImportFromMenu()
    {
        string folder = EditorUtility.OpenFolderPanel("reefgen Unity bundle (the folder with reefgen-unity.json)", "", "");
        if (string.IsNullOrEmpty(folder)) return;
        try
        {
            Import(folder);
        }
        catch (Exception e)
        {
            EditorUtility.DisplayDialog("reefgen", e.Message, "OK");
        }
        finally
        {
            EditorUtility.ClearProgressBar();
        }
    }

    // Imports the bundle in `folder`; returns the parent object of its tiles.
    public static GameObject Import(string folder)
    {
        Bundle b = ReadBundle(folder);
        string assets = AssetFolder("Assets/reefgen/" + b.name);
        TerrainLayer[] layers = MakeLayers(b, assets);
        GameObject parent = new GameObject(b.name);
        int n = b.tiles_per_axis;
        Terrain[,] grid = new Terrain[n, n];
        for (int i = 0; i < b.tiles.Length; ++i)
        {
            Tile t = b.tiles[i];
            EditorUtility.DisplayProgressBar("reefgen", "Tile " + (i + 1) + " of " + b.tiles.Length, (float)i / b.tiles.Length);
            TerrainData data = new TerrainData();
            data.heightmapResolution = b.tile_side_px;
            data.size = new Vector3(b.terrain_size_m[0], b.terrain_size_m[1], b.terrain_size_m[2]);
            data.SetHeights(0, 0, ReadHeights(Path.Combine(folder, t.raw), b.tile_side_px));
            data.alphamapResolution = b.alphamap_px;
            data.terrainLayers = layers;
            data.SetAlphamaps(0, 0, ReadWeights(folder, t, b.alphamap_px, layers.Length));
            string stem = Path.GetFileNameWithoutExtension(t.raw);
            AssetDatabase.CreateAsset(data, assets + "/" + stem + ".asset");
            GameObject go = Terrain.CreateTerrainGameObject(data);
            go.name = stem;
            go.transform.parent = parent.transform;
            go.transform.position = new Vector3(t.position_m[0], t.position_m[1], t.position_m[2]);
            Terrain terrain = go.GetComponent<Terrain>();
            terrain.allowAutoConnect = true;
            grid[t.x, t.z] = terrain;
        }
        Connect(grid, n);
        AssetDatabase.SaveAssets();
        return parent;
    }

    static Bundle ReadBundle(string folder)
    {
        string path = Path.Combine(folder, "reefgen-unity.json");
        if (!File.Exists(path))
            throw new Exception(folder + " holds no reefgen-unity.json: pick the NAME.unity folder reefgen wrote (--for unity)");
        Bundle b = JsonUtility.FromJson<Bundle>(File.ReadAllText(path));
        if (b == null || b.engine != "unity" || b.tiles == null || b.tiles.Length == 0 || b.tile_side_px < 33 ||
            b.terrain_size_m == null || b.terrain_size_m.Length != 3 || b.layers == null)
            throw new Exception(path + " is not a reefgen Unity bundle description; write the bundle again with --for unity");
        return b;
    }

    // Heights 0…1 of a tile: 16-bit little-endian samples, the southern row
    // first, as TerrainData's rows run from Z = 0.
    static float[,] ReadHeights(string path, int side)
    {
        byte[] bytes = File.ReadAllBytes(path);
        if (bytes.Length != 2 * side * side)
            throw new Exception(path + ": " + bytes.Length + " bytes, expected " + (2 * side * side) + " (" + side + "² 16-bit samples)");
        float[,] h = new float[side, side];
        for (int y = 0; y < side; ++y)
            for (int x = 0; x < side; ++x)
            {
                int k = 2 * (y * side + x);
                h[y, x] = (bytes[k] | (bytes[k + 1] << 8)) / 65535f;
            }
        return h;
    }

    // The eight weights 0…1 of a tile from its two RGBA splat PNGs (layers
    // 1-4 and 5-8). A PNG's top row is north; a loaded texture's row 0 is
    // its bottom, south, as the alphamap's.
    static float[,,] ReadWeights(string folder, Tile t, int side, int count)
    {
        float[,,] w = new float[side, side, count];
        for (int s = 0; s < t.splat.Length; ++s)
        {
            string path = Path.Combine(folder, t.splat[s]);
            Texture2D tex = new Texture2D(2, 2, TextureFormat.RGBA32, false);
            if (!ImageConversion.LoadImage(tex, File.ReadAllBytes(path)) || tex.width != side || tex.height != side)
                throw new Exception(path + ": not a " + side + "² RGBA PNG");
            Color32[] px = tex.GetPixels32();
            UnityEngine.Object.DestroyImmediate(tex);
            for (int y = 0; y < side; ++y)
                for (int x = 0; x < side; ++x)
                {
                    Color32 c = px[y * side + x];
                    int m = 4 * s;
                    if (m + 0 < count) w[y, x, m + 0] = c.r / 255f;
                    if (m + 1 < count) w[y, x, m + 1] = c.g / 255f;
                    if (m + 2 < count) w[y, x, m + 2] = c.b / 255f;
                    if (m + 3 < count) w[y, x, m + 3] = c.a / 255f;
                }
        }
        return w;
    }

    // One TerrainLayer per material, in the bundle's order, each with a
    // plain swatch of the material's colour (replace them with your own
    // textures; the weights stay).
    static TerrainLayer[] MakeLayers(Bundle b, string assets)
    {
        TerrainLayer[] layers = new TerrainLayer[b.layers.Length];
        for (int m = 0; m < layers.Length; ++m)
        {
            Texture2D swatch = new Texture2D(4, 4, TextureFormat.RGBA32, false);
            Color colour = b.layer_colours != null && b.layer_colours.Length >= 3 * (m + 1)
                ? new Color(b.layer_colours[3 * m], b.layer_colours[3 * m + 1], b.layer_colours[3 * m + 2])
                : Color.grey;
            for (int y = 0; y < 4; ++y)
                for (int x = 0; x < 4; ++x) swatch.SetPixel(x, y, colour);
            swatch.Apply();
            AssetDatabase.CreateAsset(swatch, assets + "/" + b.layers[m] + ".swatch.asset");
            TerrainLayer layer = new TerrainLayer();
            layer.name = b.layers[m];
            layer.diffuseTexture = swatch;
            layer.tileSize = new Vector2(10, 10);
            AssetDatabase.CreateAsset(layer, assets + "/" + b.layers[m] + ".terrainlayer");
            layers[m] = layer;
        }
        return layers;
    }

    // Neighbours: X east, Z north; Unity's order is left, top, right, bottom.
    static void Connect(Terrain[,] grid, int n)
    {
        for (int z = 0; z < n; ++z)
            for (int x = 0; x < n; ++x)
            {
                if (grid[x, z] == null) continue;
                Terrain left = x > 0 ? grid[x - 1, z] : null, right = x + 1 < n ? grid[x + 1, z] : null;
                Terrain top = z + 1 < n ? grid[x, z + 1] : null, bottom = z > 0 ? grid[x, z - 1] : null;
                grid[x, z].SetNeighbors(left, top, right, bottom);
            }
    }

    // Makes Assets/a/b/… folder by folder; returns its path.
    static string AssetFolder(string path)
    {
        string[] parts = path.Split('/');
        string at = parts[0];
        for (int i = 1; i < parts.Length; ++i)
        {
            string next = at + "/" + parts[i];
            if (!AssetDatabase.IsValidFolder(next)) AssetDatabase.CreateFolder(at, parts[i]);
            at = next;
        }
        return at;
    }
}
#endif
